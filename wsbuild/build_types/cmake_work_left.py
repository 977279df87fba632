"""What CMake's generator would still run right after a build: `ninja -n -d explain` (or
`make -n`), less CMake's own bookkeeping, the copies CMake makes the same every time
(`cmake -E copy…`) and the always-run targets a build type knows to make the same files from
what they read (`deterministic`). What is left makes the build volatile: its build system runs
every time (record/dirty.py)."""

from __future__ import annotations

import re
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path

from wsbuild.patterns import lazy

NINJA = "Ninja"
DEFAULT_GENERATOR = "Unix Makefiles"
#: seconds `ninja -n` / `make -n` may take after a build
_WORK_LEFT_SECONDS = 60
#: what `make -n` prints for CMake's own bookkeeping in a Makefile project
_MAKE_BOOKKEEPING = ("--check-build-system", "cmake_progress_start", "cmake_depends",
                     "cmake_echo_color", "make -s -f", "make -f", "make[", "make:")


#: `cmake -E` commands that make the same files from the same files (ament_cmake_python's
#: always-run copy of generated Python code): work left of only these is no volatile build,
#: what they copy from is in the build directory, made from what the record holds
_SAME_FROM_SAME = lazy(r"^(?:cd \S+ && )?\S*cmake -E (?:copy|copy_directory|"
                             r"copy_if_different|make_directory|echo|echo_append|true)\b"
                             r"(?:(?! && | ; |\|).)*$")


def _work_left(output: str, generator: str, deterministic: Sequence[str]) -> list[str]:
    """The commands of `ninja -n -d explain` / `make -n` the build would run (not CMake's
    bookkeeping, not a copy CMake makes the same every time, not a target of `deterministic`
    (fnmatch patterns of the outputs Ninja explains))."""
    import fnmatch

    left: list[str] = []
    outputs: list[str] = []
    for line in output.splitlines():
        if generator != NINJA:
            command = line.strip()
            if command and not any(mark in command for mark in _MAKE_BOOKKEEPING) \
                    and _SAME_FROM_SAME.match(command) is None:
                left.append(command)
            continue
        explained = re.match(r"ninja explain: (?:output )?(\S+)", line)
        if explained:
            outputs.append(explained.group(1))
            continue
        if not line.startswith("["):
            continue
        command = line.split("] ", 1)[-1]
        known = outputs and all(any(fnmatch.fnmatch(out, pattern) for pattern in deterministic)
                                for out in outputs)
        outputs = []
        if not known and _SAME_FROM_SAME.match(command) is None:
            left.append(command)
    return left


def work_left(build_dir: Path, generator: str, ninja: Path | None, target: str | None,
              environ: Mapping[str, str], deterministic: Sequence[str]) -> str:
    """Why the build system still has work right after the build, in one line ("" when it
    has none, or cannot be asked)."""
    if generator == NINJA and ninja is not None:
        command = [str(ninja), "-C", str(build_dir), "-n", "-d", "explain"]
    elif generator == DEFAULT_GENERATOR:
        command = ["make", "-C", str(build_dir), "-n"]
    else:
        return ""
    if target:
        command.append(target)
    env = {k: v for k, v in environ.items() if k not in ("MAKEFLAGS", "MFLAGS")}
    try:
        # Ninja explains on stderr, in the order of what it prints on stdout
        done = subprocess.run(command, env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True,
                              timeout=_WORK_LEFT_SECONDS, check=False,
                              stdin=subprocess.DEVNULL)
    except (OSError, subprocess.SubprocessError):
        return ""
    left = _work_left(done.stdout, generator, deterministic)
    if not left:
        return ""
    shown = re.sub(r"^cd \S+ && ", "", left[0])
    if len(shown) > 120:  # paths by their names: what runs, not where
        shown = re.sub(r"/\S*/", "", shown)
    shown = shown if len(shown) <= 120 else shown[:117] + "..."
    return f"right after the build, {generator} still runs: {shown}"
