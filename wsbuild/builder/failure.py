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
from wsbuild.engine.process import format_command
from wsbuild.workspace.resolve import ament_index
from wsbuild.patterns import lazy

if TYPE_CHECKING:
    from wsbuild.build_types import StepFailed
    from wsbuild.session import Session
    from wsbuild.workspace.selection import Selection

#: a line that says why a step failed: a compiler's `file:line: error:`, a CMake error, the
#: last line of a Python traceback (`catkin_pkg.package.InvalidPackage: …`), a tool's
#: `error:`/`Error:`
_WHY = lazy(r"^(\S+:\d+(:\d+)?: (fatal )?error: |CMake Error|(error|ERROR|Error): "
                  r"|[A-Za-z_][\w.]*(Error|Exception|InvalidPackage|Invalid\w+)( \w+)?: )")
#: ... best of all one naming the file and line (`setup.py:23: NameError: …`)
_LOCATED = lazy(r"^\S+:\d+(:\d+)?: ((fatal )?error: |[A-Za-z_][\w.]*(Error|Exception)\b)")
#: how many lines after the first such line belong to it (an exception's message)
_WHY_LINES = 4


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
    """The last `lines` of the step's log, led by the line that says why it failed (and those
    that go with it) when that came earlier (`why_lines`), indented."""
    path = log_dir / "stdout_stderr.log"
    if not path.exists():
        return []
    text = path.read_text(errors="replace").splitlines()
    tail = text[-lines:]
    why = why_lines(text)
    lead = [*why, "..."] if why and why[0] != tail[0] else []
    return [f"    {line}" for line in (*lead, *tail)]


def why_lines(lines: Sequence[str]) -> list[str]:
    """The first line of `lines` that says why a step failed, with the lines that continue it
    (up to a blank line, the next such line, or `_WHY_LINES` in all); one naming a file and
    line first; [] when none does."""
    start = next((i for i, line in enumerate(lines) if _LOCATED.match(line)), None)
    if start is None:
        start = next((i for i, line in enumerate(lines) if _WHY.match(line)), None)
    if start is None:
        return []
    found = [lines[start]]
    for more in lines[start + 1:start + _WHY_LINES]:
        if not more.strip() or _WHY.match(more) or more.startswith("-- "):
            break
        found.append(more)
    return found


def interesting(lines: list[str]) -> list[str]:
    """stderr lines worth showing; CMake's message() chatter and blank lines are not problems."""
    return [line for line in lines if line.strip() and not line.startswith("-- ")]


def with_unresolved(result: JobResult, unresolved: Sequence[str], selection: Selection,
                    session: Session) -> JobResult:
    """A failed package's report with the build dependencies it declared that were not found
    after it: the likely cause, next to the error, with what provides each (its wheel, that
    it has none, a did-you-mean among the known names: underlay/wheels.py)."""
    if result.outcome is not Outcome.FAILED or not unresolved:
        return result
    from wsbuild.underlay.wheels import install_hint  # lazy: off the full no-op build

    known = known_names(selection, session)
    pip = session.underlay.venv is not None
    lines = []
    for dep in unresolved:
        hint = install_hint(dep, known=known, pip_underlay=pip)
        lines.append(f"  declares build dependency {dep}, which was "
                     + (hint if hint.startswith("not found") else f"not found: {hint}"))
    return replace(result, message="\n".join([result.message, *lines]))


def failed_result(name: str, failure: StepFailed, build_dir: Path, log_dir: Path,
                  seconds: float) -> JobResult:
    """A failed package build's result: what failed, the tail of its log, and the command
    that reproduces the failed step (in the build directory's reproduce.sh too)."""
    from wsbuild.builder.reproduce import (
        write_reproduce_script)  # lazy: off builds that do not fail

    reproduce, script = "", None
    if failure.command:
        cwd = failure.cwd or build_dir
        reproduce = format_command(failure.command, cwd, failure.env_delta)
        script = write_reproduce_script(build_dir, name, failure.command, cwd,
                                        failure.env_delta)
    tail = log_tail(log_dir)
    message = str(failure) + ("\n" + "\n".join(tail) if tail else "")
    # the log tail in the message already shows stderr: no separate warnings block
    return JobResult(name, Outcome.FAILED, seconds, message=message, log_dir=log_dir,
                     reproduce=reproduce, reproduce_script=script)


def known_names(selection: Selection, session: Session) -> set[str]:
    """The names a misspelt dependency may have meant: the workspace's packages and those of
    the underlays' ament index."""
    prefixes = [Path(p) for p in session.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)
                if p] + session.underlay_prefixes
    return {*selection.packages, *ament_index(prefixes)}
