"""The edit–build loop with early cutoff, side by side with colcon (issue 31): a comment edited
in the root ament_python package with the most dependents of the mixed workspace (30
ament_python + 6 ament_cmake), then `build`; what each tool rebuilt, its time, the ratio.

    .venv/bin/python benchmarks/edit_loop.py            # about 3 min on 2 cores
    .venv/bin/python benchmarks/edit_loop.py --runs 1   # one edit each

Target: only the edited package rebuilt, ≤ 1 s, ≥ 20× colcon.
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.generate import GeneratedWorkspace, WorkspaceSpec, generate_workspace
from benchmarks.measure import Measurement, run_timed
from benchmarks.tools import DEFAULT_COLCON_VENV, DEFAULT_PROJECT_VENV, Log, setup_tools

#: a run records only inputs that did not change in the second before it started
SETTLE = 1.1


def most_depended_python(ws: GeneratedWorkspace) -> tuple[str, int]:
    """The ament_python package with the most (transitive) dependents, and their number."""
    users: dict[str, set[str]] = {p.name: set() for p in ws.packages}
    for package in ws.packages:
        for dep in package.depends:
            users[dep].add(package.name)

    def closure(name: str) -> set[str]:
        seen: set[str] = set()
        stack = [name]
        while stack:
            for user in users[stack.pop()]:
                if user not in seen:
                    seen.add(user)
                    stack.append(user)
        return seen

    counts = {p.name: len(closure(p.name)) for p in ws.packages
              if p.build_type == "ament_python"}
    best = max(sorted(counts), key=lambda n: counts[n])
    return best, counts[best]


def rebuilt(output: str) -> list[str]:
    return sorted(set(re.findall(r"^Finished <<< (\S+)", output, re.M)))


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="edits per tool (default 3)")
    parser.add_argument("--project-venv", type=Path, default=DEFAULT_PROJECT_VENV)
    parser.add_argument("--colcon-venv", type=Path, default=DEFAULT_COLCON_VENV)
    args = parser.parse_args(argv)
    log = Log()
    tools = setup_tools(args.project_venv, args.colcon_venv, log)
    if tools is None:
        return 2
    work = Path(tempfile.mkdtemp(prefix="wsbuild-edit-loop-"))
    spec = WorkspaceSpec(30, 6, seed=1)
    rows = []
    try:
        for tool in ("colcon", "wsbuild"):
            ws = generate_workspace(work / tool, spec)
            root, dependents = most_depended_python(ws)
            cmd = tools.colcon_cmd("build") if tool == "colcon" else tools.wsbuild_cmd("build")
            env = tools.colcon_env if tool == "colcon" else tools.wsbuild_env
            log(f"{tool}: full build of the mixed workspace")
            run_timed(cmd, cwd=ws.root, env=env, log_file=work / "edit_loop.log")
            measurement = Measurement()
            names: list[str] = []
            module = ws.module_of(root)
            for number in range(args.runs):
                time.sleep(SETTLE)
                module.write_text(module.read_text() + f"# edited comment {number}\n")
                sample = run_timed(cmd, cwd=ws.root, env=env, log_file=work / "edit_loop.log")
                measurement.samples.append(sample)
                names = rebuilt(sample.output)
            log(f"{tool}: {root} ({dependents} dependents) edited: rebuilt {len(names)}")
            rows.append((tool, root, dependents, measurement.median, names))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    colcon, wsbuild = rows
    print(f"edit a comment in {wsbuild[1]} (ament_python, {wsbuild[2]} dependents), build "
          f"(mixed 30+6, median of {args.runs}):")
    print(f"  colcon:  {colcon[3]:.2f} s, rebuilt {len(colcon[4])} packages")
    print(f"  wsbuild: {wsbuild[3]:.2f} s, rebuilt {len(wsbuild[4])}: {' '.join(wsbuild[4])}")
    print(f"  ratio: {colcon[3] / wsbuild[3]:.1f}x; target: only {wsbuild[1]}, <= 1 s, >= 20x "
          f"-> {'met' if wsbuild[4] == [wsbuild[1]] and wsbuild[3] <= 1.0 and colcon[3] / wsbuild[3] >= 20 else 'not met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
