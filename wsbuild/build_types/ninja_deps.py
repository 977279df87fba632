"""What a Ninja build read, for any build type whose build system writes build.ninja (CMake's
Ninja generator, meson): the inputs of its build statements, the prerequisites of the
depfiles Ninja reads each time (custom commands' DEPFILE), and the headers the compilers read
from Ninja's deps log (`ninja -t deps`); and the prerequisites of a makefile or depfile. A
build type's `outside_reads` reports them (build_types/cmake_reads.py does for CMake).
Public: a plugin's build type uses it as the built-in ones do."""

from __future__ import annotations

import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

from wsbuild.patterns import lazy

#: a Ninja build statement: outputs, rule, inputs (explicit | implicit || order-only)
_NINJA_BUILD = lazy(r"^build (?P<outputs>.*?)(?<!\$): (?P<rule>\S+)(?P<inputs>.*)$")
#: a Ninja path separator is an unescaped space
_NINJA_SPACE = lazy(r"(?<!\$) ")
#: seconds `ninja -t deps` may take (it reads one binary log)
NINJA_TIMEOUT = 60


def statements(path: Path) -> Iterator[str]:
    """build.ninja's lines with `$`-continuations joined."""
    pending = ""
    with open(path, encoding="utf-8", errors="replace") as handle:
        for line in handle:
            line = line.rstrip("\n")
            if line.endswith("$") and not line.endswith("$$"):
                pending += line[:-1]
                continue
            yield pending + line
            pending = ""
    if pending:
        yield pending


def paths(text: str) -> Iterator[str]:
    for token in _NINJA_SPACE.split(text.strip()):
        if token and token not in ("|", "||", "|@"):
            yield token.replace("$ ", " ").replace("$:", ":").replace("$$", "$")


def build_inputs(path: Path) -> Iterator[str]:
    """Every absolute input of every build statement: the regeneration list (the RERUN_CMAKE
    statement's inputs), libraries linked from outside, files code generators read."""
    for line in statements(path):
        if not line.startswith("build "):
            continue
        match = _NINJA_BUILD.match(line)
        if match is None:
            continue
        inputs = match.group("inputs").split(" || ")[0]
        for token in paths(inputs):
            if token.startswith("/"):
                yield token


def deps_log(build_dir: Path, ninja: Path) -> Iterator[str]:
    """The headers the compiler read, from Ninja's deps log."""
    try:
        done = subprocess.run([str(ninja), "-C", str(build_dir), "-t", "deps"],
                              capture_output=True, text=True, timeout=NINJA_TIMEOUT,
                              check=False)
    except (OSError, subprocess.TimeoutExpired):
        return
    for line in done.stdout.splitlines():
        if line.startswith("    "):
            entry = line.strip()
            yield entry if entry.startswith("/") else os.path.normpath(build_dir / entry)


def depfile_inputs(build_dir: Path) -> Iterator[str]:
    """The prerequisites the depfiles of build.ninja's statements name (custom commands'
    DEPFILE: Ninja reads them each time and keeps nothing of them in its deps log)."""
    for line in statements(build_dir / "build.ninja"):
        stripped = line.strip()
        if stripped.startswith("depfile = "):
            path = stripped[len("depfile = "):].replace("$ ", " ").replace("$$", "$")
            depfile = Path(path) if os.path.isabs(path) else build_dir / path
            yield from make_prerequisites(depfile, relative_to=build_dir)


def make_prerequisites(path: Path, relative_to: Path | None = None) -> Iterator[str]:
    """The absolute prerequisites of the rules in a makefile or depfile (commands skipped);
    with `relative_to`, the relative ones too, made absolute (a depfile Ninja reads in the
    build directory)."""
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return
    for line in text.replace("\\\n", " ").splitlines():
        if not line or line.startswith(("\t", "#")):
            continue
        _, colon, rest = line.partition(": ")
        if not colon:
            continue
        for token in rest.split():
            token = token.replace("\\ ", " ")
            if token.startswith("/"):
                yield token
            elif token and relative_to is not None:
                yield os.path.normpath(relative_to / token)
