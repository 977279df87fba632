"""Profile one wsbuild command in-process across all its threads (cProfile sees only the thread it runs in).

Usage (in the workspace, with the project venv's interpreter):

    .venv/bin/python benchmarks/profile_wsbuild.py [--out FILE] [--sort tottime] [--top 40] -- build
    .venv/bin/python benchmarks/profile_wsbuild.py -- list

Every thread (wsbuild's workers) gets its own profiler; the statistics are merged, so times are
thread-seconds (two busy workers count twice per wall second).  Child processes (cmake,
setup.py helpers) are not profiled: their time shows as waiting in `subprocess`/`select`.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import sys
import threading
import time
from collections.abc import Sequence


def profile_command(argv: Sequence[str]) -> tuple[int, pstats.Stats, float]:
    """Run `wsbuild <argv>` in this process with every thread profiled."""
    profiles: list[cProfile.Profile] = []
    lock = threading.Lock()
    original_run = threading.Thread.run

    def profiled_run(self: threading.Thread) -> None:
        profile = cProfile.Profile()
        with lock:
            profiles.append(profile)
        profile.enable()
        try:
            original_run(self)
        finally:
            profile.disable()

    threading.Thread.run = profiled_run  # type: ignore[method-assign]
    main_profile = cProfile.Profile()
    profiles.append(main_profile)
    start = time.perf_counter()
    main_profile.enable()
    try:
        from wsbuild.cli import main

        code = main(list(argv))
    except SystemExit as exc:
        code = int(exc.code or 0)
    finally:
        main_profile.disable()
        threading.Thread.run = original_run  # type: ignore[method-assign]
    wall = time.perf_counter() - start
    stats = pstats.Stats(main_profile, stream=io.StringIO())
    for profile in profiles[1:]:
        stats.add(profile)
    return code, stats, wall


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="also dump the merged statistics (for snakeviz, pstats)")
    parser.add_argument("--sort", default="tottime", choices=("tottime", "cumulative", "ncalls"))
    parser.add_argument("--top", type=int, default=40)
    parser.add_argument("wsbuild_args", nargs=argparse.REMAINDER,
                        help="after --: the wsbuild command line, e.g. -- build")
    args = parser.parse_args(argv)
    command = [a for a in args.wsbuild_args if a != "--"] or ["build"]
    code, stats, wall = profile_command(command)
    out = io.StringIO()
    stats.stream = out  # type: ignore[attr-defined]
    stats.sort_stats(args.sort).print_stats(args.top)
    print(f"\n=== wsbuild {' '.join(command)}: exit {code}, {wall:.3f}s wall, "
          f"sorted by {args.sort} (thread-seconds) ===", file=sys.stderr)
    print(out.getvalue(), file=sys.stderr)
    if args.out:
        stats.dump_stats(args.out)
    return code


if __name__ == "__main__":
    sys.exit(main())
