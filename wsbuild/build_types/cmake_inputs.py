"""The files outside a CMake package that its last build read, from CMake's and the
generator's own dependency lists (cargo's dep-info idea): the files whose change makes CMake
configure again (its regeneration list), the libraries and other files build rules name, and
the headers the compiler read (Ninja's deps log, `ninja -t deps`; Make's depfiles).

These are what `cmake --build` (what colcon runs every time) would notice; recorded with the
package's build state, a change to any of them makes the package's plan say "build"."""

from __future__ import annotations

import os
import re
import subprocess
from collections.abc import Iterable, Iterator
from pathlib import Path

#: a Ninja build statement: outputs, rule, inputs (explicit | implicit || order-only)
_NINJA_BUILD = re.compile(r"^build (?P<outputs>.*?)(?<!\$): (?P<rule>\S+)(?P<inputs>.*)$")
#: a Ninja path separator is an unescaped space
_NINJA_SPACE = re.compile(r"(?<!\$) ")
#: CMake's regeneration list in Makefile projects
_MAKEFILE_DEPENDS = re.compile(r"set\(CMAKE_MAKEFILE_DEPENDS\s+(.*?)\)", re.DOTALL)
#: seconds `ninja -t deps` may take (it reads one binary log)
_NINJA_TIMEOUT = 60


def external_inputs(build_dir: Path, source_dir: Path, ninja: Path | None) -> list[str]:
    """Absolute paths, outside `source_dir` and `build_dir`, that the build in `build_dir`
    read, sorted; [] when the build directory holds no generator files."""
    if (build_dir / "build.ninja").is_file():
        found = set(_ninja_build_inputs(build_dir / "build.ninja"))
        if ninja is not None:
            found.update(_ninja_deps(build_dir, ninja))
    else:
        found = set(_makefile_inputs(build_dir))
    inside = (str(source_dir) + os.sep, str(build_dir) + os.sep)
    return sorted(p for p in found if p.startswith("/") and not p.startswith(inside))


def _ninja_statements(path: Path) -> Iterator[str]:
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


def _ninja_paths(text: str) -> Iterator[str]:
    for token in _NINJA_SPACE.split(text.strip()):
        if token and token not in ("|", "||", "|@"):
            yield token.replace("$ ", " ").replace("$:", ":").replace("$$", "$")


def _ninja_build_inputs(path: Path) -> Iterator[str]:
    """Every absolute input of every build statement: the regeneration list (the RERUN_CMAKE
    statement's inputs), libraries linked from outside, files code generators read."""
    for line in _ninja_statements(path):
        if not line.startswith("build "):
            continue
        match = _NINJA_BUILD.match(line)
        if match is None:
            continue
        inputs = match.group("inputs").split(" || ")[0]
        for token in _ninja_paths(inputs):
            if token.startswith("/"):
                yield token


def _ninja_deps(build_dir: Path, ninja: Path) -> Iterator[str]:
    """The headers the compiler read, from Ninja's deps log."""
    try:
        done = subprocess.run([str(ninja), "-C", str(build_dir), "-t", "deps"],
                              capture_output=True, text=True, timeout=_NINJA_TIMEOUT,
                              check=False)
    except (OSError, subprocess.TimeoutExpired):
        return
    for line in done.stdout.splitlines():
        if line.startswith("    "):
            entry = line.strip()
            yield entry if entry.startswith("/") else os.path.normpath(build_dir / entry)


def _makefile_inputs(build_dir: Path) -> Iterator[str]:
    """Makefile projects: CMake's regeneration list, and every prerequisite named in the
    targets' rules and compiler depfiles (`compiler_depend.make`, `*.d`, `depend.make`)."""
    try:
        text = (build_dir / "CMakeFiles" / "Makefile.cmake").read_text(errors="replace")
    except OSError:
        return
    match = _MAKEFILE_DEPENDS.search(text)
    if match:
        for token in re.findall(r'"([^"]*)"', match.group(1)):
            yield token
    for path in _walk_files(build_dir / "CMakeFiles"):
        name = path.name
        if name in ("build.make", "compiler_depend.make", "depend.make") or name.endswith(".d"):
            yield from _make_prerequisites(path)


def _walk_files(root: Path) -> Iterable[Path]:
    for directory, _, names in os.walk(root):
        for name in names:
            yield Path(directory, name)


def _make_prerequisites(path: Path) -> Iterator[str]:
    """The absolute prerequisites of the rules in a makefile or depfile (commands skipped)."""
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
