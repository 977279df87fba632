"""`test` again with nothing changed, side by side with colcon (issue 31): the mixed workspace
(benchmarks/generate.py) with real tests added to every package, built by each tool in its own
copy, then `test` run twice. wsbuild's second run reuses every passing result (cached); colcon
runs every test again. Also: `test` after editing one leaf package (only its tests may run).

    .venv/bin/python benchmarks/test_cache.py            # 36 packages, about 6 min on 2 cores
    .venv/bin/python benchmarks/test_cache.py --quick    # 8 packages, under 3 minutes

Targets: `test` again with nothing changed ≤ 2 s and ≥ 50× colcon `test`; after one leaf
package is edited (and built), only that package's tests run. The Markdown table goes to
stdout, progress to stderr, every command's output to <work-dir>/bench.log.
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.generate import GeneratedWorkspace, WorkspaceSpec, generate_workspace
from benchmarks.measure import Measurement, Sample, repeat, run_timed
from benchmarks.tools import (
    DEFAULT_COLCON_VENV,
    DEFAULT_PROJECT_VENV,
    Log,
    Tools,
    machine_details,
    setup_tools,
)

#: a real test module for every ament_python package: its node imported and exercised
PYTHON_TEST = '''import pytest

from {name} import node


def test_the_node_has_a_main():
    assert callable(node.main)


@pytest.mark.parametrize("value", range(20))
def test_arithmetic_of_{name}(value):
    assert sum(range(value + 1)) == value * (value + 1) // 2


def test_strings():
    assert "{name}".startswith("bench_")
'''

#: CTest tests for every ament_cmake package (before ament_package())
CMAKE_TESTS = """enable_testing()
add_test(NAME params_exist COMMAND test -f ${CMAKE_CURRENT_SOURCE_DIR}/config/params.yaml)
add_test(NAME cmake_runs COMMAND ${CMAKE_COMMAND} -E echo ${PROJECT_NAME})
"""

_CACHED = re.compile(r"^\[(\S+)\] cached: ", re.MULTILINE)
_STARTED = re.compile(r"^Starting >>> (\S+)", re.MULTILINE)
_TOTALS = re.compile(r"^Summary: \d+ packages? tested, (.*?) \[", re.MULTILINE)


def add_tests(workspace: GeneratedWorkspace) -> None:
    """Real tests in every package of a generated workspace."""
    for package in workspace.packages:
        base = workspace.root / package.path
        if package.build_type == "ament_python":
            # setuptools ≥ 72 drops tests_require: colcon finds pytest in the `test` extra
            setup_py = base / "setup.py"
            setup_py.write_text(setup_py.read_text().replace(
                "tests_require=['pytest'],",
                "tests_require=['pytest'],\n    extras_require={'test': ['pytest']},"))
            (base / "test").mkdir(exist_ok=True)
            (base / "test" / f"test_{package.name}.py").write_text(
                PYTHON_TEST.format(name=package.name))
        else:
            cmakelists = base / "CMakeLists.txt"
            text = cmakelists.read_text()
            cmakelists.write_text(text.replace("ament_package()",
                                               CMAKE_TESTS + "\nament_package()"))


@dataclass(slots=True)
class TestCacheBench:
    __test__ = False  # not a pytest test class

    tools: Tools
    work: Path
    log: Log
    rows: list[list[str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def log_file(self) -> Path:
        return self.work / "bench.log"

    def wsbuild(self, ws: Path, *args: str) -> Sample:
        return run_timed(self.tools.wsbuild_cmd(*args), cwd=ws, env=self.tools.wsbuild_env,
                         log_file=self.log_file)

    def colcon(self, ws: Path, *args: str) -> Sample:
        return run_timed(self.tools.colcon_cmd(*args), cwd=ws, env=self.tools.colcon_env,
                         log_file=self.log_file)

    def run(self, spec: WorkspaceSpec, *, wsbuild_runs: int, colcon_runs: int) -> None:
        own = generate_workspace(self.work / "ws_wsbuild", spec)
        theirs = generate_workspace(self.work / "ws_colcon", spec)
        add_tests(own)
        add_tests(theirs)
        label = f"mixed {spec.total} packages ({spec.python_packages} ament_python + " \
                f"{spec.cmake_packages} ament_cmake)"
        self.log(f"{label}: building with both tools (not timed)")
        self.wsbuild(own.root, "build")
        self.colcon(theirs.root, "build")

        self.log("first `test` of each tool")
        first = self.wsbuild(own.root, "test")
        colcon_first = self.colcon(theirs.root, "test")
        self.log(f"`test` again, nothing changed: wsbuild ×{wsbuild_runs}, colcon ×{colcon_runs}")
        again = repeat(self.tools.wsbuild_cmd("test"), wsbuild_runs, cwd=own.root,
                       env=self.tools.wsbuild_env, log_file=self.log_file)
        colcon_again = Measurement([colcon_first])
        colcon_again.samples += repeat(self.tools.colcon_cmd("test"), colcon_runs - 1,
                                       cwd=theirs.root, env=self.tools.colcon_env,
                                       log_file=self.log_file).samples
        self.notes.append(f"colcon reruns every test each time: its `test again` figure is the "
                          f"median of its {colcon_runs} runs, the first included")
        self._check_again(first, again, spec.total)
        colcon_results = self.colcon(theirs.root, "test-result").output.strip().splitlines()
        self.notes.append(f"colcon test-result: {colcon_results[-1] if colcon_results else '?'}"
                          f"; wsbuild: {_totals(first)}")
        ratio = colcon_again.median / again.median
        self.rows.append(["`test` again, nothing changed", f"{colcon_again.median:.2f} s",
                          f"{again.median:.2f} s", f"{ratio:.0f}×", "≤ 2 s, ≥ 50×",
                          _verdict(again.median <= 2.0 and ratio >= 50)])
        self.rows.append(["first `test` (every test runs)", f"{colcon_first.seconds:.2f} s",
                          f"{first.seconds:.2f} s",
                          f"{colcon_first.seconds / first.seconds:.1f}×", "", ""])
        self._leaf_edit(own)

    def _check_again(self, first: Sample, again: Measurement, total: int) -> None:
        for sample in again.samples:
            cached = _CACHED.findall(sample.output)
            started = _STARTED.findall(sample.output)
            if started or len(cached) != total or _totals(sample) != _totals(first):
                self.notes.append(f"CHECK FAILED: a repeated `wsbuild test` ran {started}, "
                                  f"showed {len(cached)} of {total} cached, totals "
                                  f"{_totals(sample)} (first: {_totals(first)})")
                return
        self.notes.append(f"every repeated `wsbuild test` showed all {total} packages cached "
                          "with the first run's totals and started no test")

    def _leaf_edit(self, workspace: GeneratedWorkspace) -> None:
        leaf = workspace.leaves()[0]
        module = workspace.module_of(leaf)
        module.write_text(module.read_text() + "# edited by the benchmark\n")
        self.wsbuild(workspace.root, "build")
        tested = self.wsbuild(workspace.root, "test")
        started = sorted(_STARTED.findall(tested.output))
        others = [name for name in started if name != leaf]
        if others:  # why, as the package's log says (e.g. the system's packages changed)
            run_log = sorted((workspace.root / "log").glob("test_*"))[-1]
            why = (run_log / others[0] / "command.log").read_text().splitlines()[0]
            self.notes.append(f"after the leaf edit {others[0]} ran too: {why}")
        self.rows.append([f"`test` after editing leaf {leaf} (and building)", "",
                          f"{tested.seconds:.2f} s", "",
                          "only that package's tests run",
                          _verdict(started == [leaf]) + f" (ran: {' '.join(started) or 'none'})"])


def _totals(sample: Sample) -> str:
    found = _TOTALS.search(sample.output)
    return found.group(1) if found else "?"


def _verdict(met: bool) -> str:
    return "met" if met else "**missed**"


def render(bench: TestCacheBench, machine: dict[str, str], command: str) -> str:
    lines = ["## Test results cached (`benchmarks/test_cache.py`)", "",
             f"`{command}` on {machine.get('CPU model', '?')}, {machine.get('CPUs', '?')} CPUs; "
             f"wsbuild {machine.get('wsbuild', '?')}, colcon {machine.get('colcon', '?')}.", "",
             "| scenario | colcon | wsbuild | ratio | target | |",
             "|---|---:|---:|---:|---|---|"]
    lines += [f"| {' | '.join(row)} |" for row in bench.rows]
    lines += ["", "Medians of wall-clock time."]
    lines += [f"- {note}" for note in bench.notes]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/test_cache.py", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true",
                        help="8 packages and fewer runs (under 3 minutes)")
    parser.add_argument("--project-venv", type=Path, default=DEFAULT_PROJECT_VENV)
    parser.add_argument("--colcon-venv", type=Path, default=DEFAULT_COLCON_VENV)
    parser.add_argument("--work-dir", type=Path,
                        default=Path.home() / ".cache" / "wsbuild-bench" / "test_cache")
    args = parser.parse_args(argv)
    log = Log()
    tools = setup_tools(args.project_venv, args.colcon_venv, log)
    if tools is None:
        return 2
    work = args.work_dir.resolve()
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    bench = TestCacheBench(tools, work, log)
    if args.quick:
        bench.run(WorkspaceSpec(6, 2), wsbuild_runs=3, colcon_runs=1)
    else:
        bench.run(WorkspaceSpec(30, 6), wsbuild_runs=5, colcon_runs=2)
    command = "python benchmarks/test_cache.py" + (" --quick" if args.quick else "")
    print(render(bench, machine_details(tools), command))
    return 0


if __name__ == "__main__":
    start = time.monotonic()
    code = main()
    print(f"({time.monotonic() - start:.0f} s)", file=sys.stderr)
    raise SystemExit(code)
