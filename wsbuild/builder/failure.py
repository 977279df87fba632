"""What a failed package build says: its failed command's exit status in a user's words, the
tail of its log, and which stderr lines are worth showing."""

from __future__ import annotations

import os
import signal
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.words import did_you_mean

if TYPE_CHECKING:
    from wsbuild.session import Session
    from wsbuild.workspace.selection import Selection


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


def with_unresolved(result: JobResult, unresolved: Sequence[str], selection: Selection,
                    session: Session) -> JobResult:
    """A failed package's report with the build dependencies it declared that were not found
    after it: the likely cause, next to the error (with a did-you-mean among the workspace's
    packages and those of the underlays' ament index)."""
    if result.outcome is not Outcome.FAILED or not unresolved:
        return result
    from wsbuild.workspace.resolve import ament_index

    prefixes = [Path(p) for p in session.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)
                if p] + session.underlay_prefixes
    known = {*selection.packages, *ament_index(prefixes)}
    lines = [f"  declares build dependency {dep}, which was not found"
             + (f" ({hint})" if (hint := did_you_mean(dep, known)) else "")
             for dep in unresolved]
    return replace(result, message="\n".join([result.message, *lines]))
