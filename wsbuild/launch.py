"""The `wsbuild` command: `wsbuild --version` is answered before anything is imported, and a
command whose inputs did not change since its last run (a no-op build, `list`, `graph`,
`info`) is replayed from that run's record (engine/replay.py); everything else goes to cli.py,
with the sourced workspaces' Python paths searched last."""

from __future__ import annotations

import gc
import os
import sys

from wsbuild import __version__

#: allocations (net of deallocations) between two collections of the youngest generation
GC_THRESHOLD = 100_000

TYPE_CHECKING = False
if TYPE_CHECKING:
    from wsbuild.reporter import ReplayDrawing


def main() -> int:
    argv = sys.argv[1:]
    if argv == ["--version"]:
        print(f"wsbuild {__version__}")
        return 0
    search_pythonpath_last()
    # before any module of wsbuild defines a dataclass: their methods' code, kept between runs
    from wsbuild import dataclass_code  # lazy: off `--version`

    dataclass_code.keep()
    # the cyclic garbage collector less often: a plan makes tens of thousands of small
    # objects that live to the end (each record's reads), and at the interpreter's default
    # (700) it walked them all again and again, a tenth of a full no-op of 60 packages;
    # cycles are still collected while a long build runs (mypy does the same)
    gc.set_threshold(GC_THRESHOLD, 20, 20)
    from wsbuild.engine import replay  # lazy: off `--version`

    if not argv or argv[0] not in replay.VERBS:
        from wsbuild.cli import main as run_command_line  # lazy: off the replayed no-op

        return run_command_line(argv)
    try:
        replayed = replay.replay(argv, _drawing)
    except KeyboardInterrupt:
        print("wsbuild: interrupted", file=sys.stderr)
        return 130
    if replayed is not None:
        return replayed
    from wsbuild.engine.recording import recording  # lazy: off the replayed no-op

    # the standard library's sysconfig probes the interpreter's own installation when first
    # imported (Modules/Setup): the interpreter's start, whose path and version key the record
    import sysconfig  # noqa: F401

    with recording(argv) as recorder:
        from wsbuild.cli import main as run_command_line  # lazy: off the replayed no-op

        code = run_command_line(argv, recorder=recorder)
        if recorder is not None:
            recorder.finish(code)
    return code


def _drawing() -> ReplayDrawing:
    """The reporter's side of a replayed build (imported only when a build is replayed)."""
    from wsbuild.reporter import ReplayDrawing  # lazy: off a replayed `list` and `--version`

    return ReplayDrawing()


def search_pythonpath_last() -> None:
    """A sourced workspace puts every package's site-packages on PYTHONPATH, ahead of the
    standard library and the venv: every module wsbuild imports would first be looked for in
    each (a workspace of 1,000 packages: half a second). wsbuild needs none of them first, so
    they move behind its own paths; they stay on the path (a build type that another
    distribution installed into an overlay still loads) and the environment of the commands
    wsbuild runs is not touched."""
    entries = {os.path.abspath(p) for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p}
    if len(entries) < 2:
        return
    moved = [p for p in sys.path[1:] if p and os.path.abspath(p) in entries]
    if moved:
        kept = [p for p in sys.path[1:] if p not in moved]
        sys.path[1:] = [*kept, *moved]
