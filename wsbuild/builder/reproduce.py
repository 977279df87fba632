"""The script that reproduces a failed step by hand: `build/<pkg>/reproduce.sh` goes to the
step's directory, sets the environment the step had (a dozen library directories, the
underlay's paths) and runs its command, so the screen shows a short path instead of a line of
2,000 characters. The whole line stays in the package's `command.log` and the run's report."""

from __future__ import annotations

import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path

from wsbuild.files import atomic_write

SCRIPT = "reproduce.sh"


def script_text(package: str, command: Sequence[str], cwd: Path,
                delta: Mapping[str, str]) -> str:
    """The script: POSIX sh, one variable a line, the command last (exec'd, so its exit code
    is the script's)."""
    lines = ["#!/bin/sh",
             f"# {package}: the step `wsbuild build` saw fail, by hand in a fresh shell",
             f"cd {shlex.quote(str(cwd))} || exit 1"]
    lines += [f"export {name}={shlex.quote(value)}" for name, value in delta.items()]
    lines.append("exec " + shlex.join(command))
    return "\n".join(lines) + "\n"


def write_reproduce_script(build_dir: Path, package: str, command: Sequence[str], cwd: Path,
                           delta: Mapping[str, str]) -> Path:
    """Write `build_dir/reproduce.sh` (executable, readable by the user only: it holds the
    step's environment) and return its path."""
    build_dir.mkdir(parents=True, exist_ok=True)
    path = build_dir / SCRIPT
    atomic_write(path, script_text(package, command, cwd, delta), mode=0o700)
    return path
