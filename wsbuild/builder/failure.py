"""What a failed package build says: its failed command's exit status in a user's words, the
tail of its log, and which stderr lines are worth showing."""

from __future__ import annotations

import signal
from collections.abc import Sequence
from pathlib import Path


def exit_text(program: str, returncode: int, tail: Sequence[str]) -> str:
    """What a failed command's exit status means, in the words a user needs."""
    if returncode == 127 and tail and tail[0].startswith(f"cannot run {program}"):
        return (f"'{program}' is not installed or not on PATH: install it, or put the "
                "directory holding it on PATH, and build again")
    if returncode < 0:
        try:
            name = signal.Signals(-returncode).name
        except ValueError:
            name = f"signal {-returncode}"
        cause = " (out of memory, or stopped from outside)" if name == "SIGKILL" else ""
        return f"'{program}' was killed by {name}{cause}"
    return f"'{program}' exited with code {returncode}"


def log_tail(log_dir: Path, lines: int = 15) -> list[str]:
    path = log_dir / "stdout_stderr.log"
    if not path.exists():
        return []
    text = path.read_text(errors="replace").splitlines()
    return [f"    {line}" for line in text[-lines:]]


def interesting(lines: list[str]) -> list[str]:
    """stderr lines worth showing; CMake's message() chatter and blank lines are not problems."""
    return [line for line in lines if line.strip() and not line.startswith("-- ")]
