"""The commands users run most, side by side with colcon: a no-op build (nothing changed), `list`
of a large workspace, and `wsbuild --version` — with where a no-op's time goes.

    .venv/bin/python benchmarks/noop.py            # about 6 min on 2 cores; writes its section
    .venv/bin/python benchmarks/noop.py --quick    # smaller workspaces, fewer runs, no docs

Scenarios and targets (issues 23 and 44): no-op of the mixed 36-package workspace (≤ 100 ms
replayed, ≥ 200× colcon; ≤ 200 ms the first after a change), no-op of about 60 packages shaped
like real code (`real_shaped`: ≤ 150 ms replayed, ≤ 300 ms the first after a change), no-op of
the upstream-pattern corpus (tests/data/corpus) built with default flags (≤ 120 ms), no-op of
1,000 synthetic packages (≤ 400 ms replayed), `list` of 1,000 packages (≤ 150 ms, ≥ 25×
colcon), `wsbuild --version` (≤ 60 ms). Each wsbuild command runs as the README's user
runs it (the venv's `wsbuild` command, bin/wsbuild): in a fresh terminal with the project venv
activated, and again after `source install/setup.bash`, which sets the ROS wheels'
bootstrapper's guard (the command sets it for its own start, so the bootstrapper never starts
the interpreter twice; `python -c pass` shows what that second start would cost). The breakdown comes from the same runs: the interpreter alone (`python -c
pass`), `--version`, the run's own time (its Summary line), and `python -X importtime`.
"""

from __future__ import annotations

import argparse
import datetime
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.generate import WorkspaceSpec, generate_workspace
from benchmarks.measure import Measurement, clean_outputs, repeat, run_timed
from benchmarks.tools import (
    DEFAULT_COLCON_VENV,
    DEFAULT_PROJECT_VENV,
    REPO,
    Log,
    Tools,
    machine_details,
    setup_tools,
    write_section,
)

DOCS = REPO / "docs" / "benchmarks.md"
BEGIN = "<!-- noop.py: begin -->"
END = "<!-- noop.py: end -->"
CORPUS = REPO / "tests" / "data" / "corpus" / "src"
GUARD = "_ROS_WHEELS_BOOTSTRAP_COMPLETE"
#: a run records only inputs that did not change in the second before it started
SETTLE = 1.1
#: where the records are, under a workspace
RECORDS = Path("build") / ".wsbuild" / "noop"
_SUMMARY = re.compile(r"^Summary: .*\[(?P<s>[\d.]+)s\]", re.MULTILINE)


def ms(value: float) -> str:
    return f"{value * 1000:.0f} ms"


class NoopBench:
    def __init__(self, tools: Tools, work_dir: Path, runs: int, log: Log) -> None:
        self.tools = tools
        self.work = work_dir
        self.runs = runs
        self.log = log
        self.log_file = work_dir / "noop.log"
        self.rows: list[tuple[str, str, str, str, str]] = []
        self.notes: list[str] = []

    def sourced_env(self, ws: Path) -> dict[str, str]:
        """The environment after `source install/setup.bash` in the activated venv."""
        script = f"source {ws / 'install' / 'setup.bash'} >/dev/null 2>&1; env -0"
        done = subprocess.run(["bash", "-c", script], env=self.tools.wsbuild_env,
                              capture_output=True, check=True)
        pairs = [item.split("=", 1) for item in done.stdout.decode().split("\0") if "=" in item]
        return {k: v for k, v in pairs}

    def wsbuild(self, ws: Path, *args: str, runs: int | None = None,
                env: dict[str, str] | None = None) -> Measurement:
        return repeat(self.tools.wsbuild_cmd(*args), runs or self.runs, cwd=ws,
                      env=env or self.tools.wsbuild_env, log_file=self.log_file)

    def colcon(self, ws: Path, *args: str, runs: int) -> Measurement:
        return repeat(self.tools.colcon_cmd(*args), runs, cwd=ws, env=self.tools.colcon_env,
                      log_file=self.log_file)

    def row(self, what: str, colcon: Measurement | None, fresh: Measurement,
            sourced: Measurement | None, target: str) -> None:
        ratio = f"{colcon.median / fresh.median:.0f}×" if colcon is not None else "–"
        self.rows.append((what, ms(colcon.median) if colcon else "–", ms(fresh.median),
                          ms(sourced.median) if sourced else "–", f"{ratio}; target {target}"))

    def settled(self, ws: Path, *args: str, env: dict[str, str]) -> None:
        """Run `wsbuild args` until it leaves a record: a run records only what did not change
        in the second before it started (engine/recording.py), and the first run in another
        environment rewrites the dependency check's memo."""
        for _ in range(2):
            run_timed(self.tools.wsbuild_cmd(*args), cwd=ws, env=env, log_file=self.log_file)
            time.sleep(SETTLE)
        run_timed(self.tools.wsbuild_cmd(*args), cwd=ws, env=env, log_file=self.log_file)

    def repeated(self, ws: Path, *args: str, env: dict[str, str] | None = None) -> Measurement:
        """The command run again and again on an unchanged workspace (replayed)."""
        env = env or self.tools.wsbuild_env
        self.settled(ws, *args, env=env)
        return self.wsbuild(ws, *args, env=env)

    def full(self, ws: Path, *args: str, env: dict[str, str] | None = None) -> Measurement:
        """The command with no record to replay: the first run after a change, in full."""
        measurement = Measurement()
        for _ in range(self.runs):
            shutil.rmtree(ws / RECORDS, ignore_errors=True)
            measurement.samples.append(run_timed(self.tools.wsbuild_cmd(*args), cwd=ws,
                                                 env=env or self.tools.wsbuild_env,
                                                 log_file=self.log_file))
        return measurement

    def noop(self, label: str, ws: Path, target: str, colcon_runs: int = 0,
             full_target: str = "–") -> None:
        self.log(f"{label}: wsbuild build (full), then no-op x{self.runs}, repeated and full")
        run_timed(self.tools.wsbuild_cmd("build"), cwd=ws, env=self.tools.wsbuild_env,
                  log_file=self.log_file)
        time.sleep(SETTLE)
        sourced_env = self.sourced_env(ws)
        full_fresh = self.full(ws, "build")
        full_sourced = self.full(ws, "build", env=sourced_env)
        fresh = self.repeated(ws, "build")
        sourced = self.repeated(ws, "build", env=sourced_env)
        own = [float(m["s"]) for s in full_fresh.samples for m in _SUMMARY.finditer(s.output)]
        if own:
            self.notes.append(f"{label}: the full run's own time (its Summary line) "
                              f"{ms(sorted(own)[len(own) // 2])} of the "
                              f"{ms(full_fresh.median)}")
        colcon = None
        if colcon_runs:
            colcon_ws = ws.parent / f"{ws.name}-colcon"
            shutil.rmtree(colcon_ws, ignore_errors=True)
            shutil.copytree(ws / "src", colcon_ws / "src", symlinks=True)
            self.log(f"{label}: colcon build, then no-op x{colcon_runs}")
            run_timed(self.tools.colcon_cmd("build"), cwd=colcon_ws, env=self.tools.colcon_env,
                      log_file=self.log_file)
            colcon = self.colcon(colcon_ws, "build", runs=colcon_runs)
        self.row(f"no-op build, {label}", colcon, fresh, sourced, target)
        self.row(f"no-op build, {label}: the first after a change (full run)", colcon,
                 full_fresh, full_sourced, full_target)

    def listing(self, ws: Path, colcon_runs: int) -> None:
        self.log(f"list, {ws.name}: wsbuild x{self.runs} full and repeated, colcon "
                 f"x{colcon_runs}")
        full = self.full(ws, "list")
        fresh = self.repeated(ws, "list")
        colcon = self.colcon(ws, "list", runs=colcon_runs)
        self.row("`list`, 1,000 packages: the first after a change (full run)", colcon, full,
                 None, "–")
        self.row("`list`, 1,000 packages, repeated", colcon, fresh, None, "≤ 150 ms, ≥ 25×")

    def version(self, ws: Path) -> None:
        fresh = self.wsbuild(ws, "--version", runs=self.runs * 2)
        guarded = dict(self.tools.wsbuild_env, **{GUARD: "1"})
        sourced = self.wsbuild(ws, "--version", runs=self.runs * 2, env=guarded)
        self.row("`wsbuild --version`", None, fresh, sourced, "≤ 60 ms")
        python = str(self.tools.project_venv / "bin" / "python")
        bare = repeat([python, "-c", "pass"], self.runs * 2, cwd=ws,
                      env=self.tools.wsbuild_env, log_file=None)
        bare_guarded = repeat([python, "-c", "pass"], self.runs * 2, cwd=ws, env=guarded,
                              log_file=None)
        self.notes.append(f"the venv's interpreter alone (`python -c pass`): {ms(bare.median)} "
                          f"in a fresh terminal, {ms(bare_guarded.median)} with the "
                          "bootstrapper's guard set (its re-exec costs the difference)")

    def importtime(self, ws: Path, *, replayed: bool) -> list[str]:
        python = str(self.tools.project_venv / "bin" / "python")
        env = dict(self.tools.wsbuild_env, **{GUARD: "1", "PYTHONPROFILEIMPORTTIME": "1"})
        # every variable reaches the packages' records: a first build in this environment
        # builds again, so the one measured is a no-op
        self.settled(ws, "build", env=env)
        if not replayed:
            shutil.rmtree(ws / RECORDS, ignore_errors=True)
        done = subprocess.run([python, "-m", "wsbuild", "build"], cwd=ws,
                              env=env, capture_output=True, text=True)
        rows = []
        for line in done.stderr.splitlines():
            parts = line.split("|")
            if len(parts) == 3 and parts[0].startswith("import time:") and "self" not in line:
                rows.append((int(parts[1]), parts[2].strip()))
        total = sum(int(line.split("|")[0].split(":")[1]) for line in done.stderr.splitlines()
                    if line.startswith("import time:") and "self" not in line)
        top = sorted(rows, reverse=True)[:8]
        which = "a repeated (replayed)" if replayed else "a full"
        return [f"imports of {which} no-op `wsbuild build` (mixed workspace, `-X importtime`): "
                f"{ms(total / 1e6)} in all; the largest (cumulative): "
                + ", ".join(f"{name} {us / 1000:.1f} ms" for us, name in top)]


def render(bench: NoopBench, details: dict[str, str], command: str, started: str,
           quick: bool) -> str:
    lines = [BEGIN, "## No-op builds and start-up", "",
             f"`{command}`, {started}" + (" (quick mode: small workspaces)" if quick else ""),
             "; ".join(f"{k}: {v}" for k, v in details.items()), "",
             "| scenario | colcon | wsbuild, fresh terminal | wsbuild, after `source "
             "install/setup.bash` | ratio; target |", "|---|---:|---:|---:|---|"]
    lines += [f"| {' | '.join(row)} |" for row in bench.rows]
    lines += ["", "Medians. \"Fresh terminal\": the project venv activated, as the README's "
              "quick start runs wsbuild (the `wsbuild` command starts the interpreter once: it "
              "sets the ROS wheels' bootstrapper's guard for its own start). After sourcing, "
              "the guard is set for every Python. "
              "\"No-op build\" and \"repeated\": the command run again on an unchanged "
              "workspace, answered from the record of the run before (engine/replay.py); "
              "\"the first after a change\": the same command with no record, so it scans, "
              "plans and records in full (what the first no-op after a real build, a `git "
              "pull` or a new terminal environment costs).", ""]
    lines += [f"- {note}" for note in bench.notes]
    lines += [END, ""]
    return "\n".join(lines)


def real_shaped(root: Path, *, quick: bool) -> tuple[Path, int]:
    """A workspace of about 60 packages shaped like real code (issue 44): the upstream-pattern
    corpus (message packages, C++ libraries with gtests, Python packages with pytest, launch
    and description packages), the compile-heavy workspace's interface packages and C++
    libraries (compile_heavy.py), and generated Python and CMake packages; the compile-heavy
    part is left out with --quick."""
    from benchmarks.compile_heavy import generate_compile_heavy

    shutil.copytree(CORPUS, root / "src" / "corpus", symlinks=True)
    count = len(list(CORPUS.iterdir()))
    if not quick:
        count += len(generate_compile_heavy(root).packages)
    generated = generate_workspace(root.parent / "real-generated",
                                   WorkspaceSpec(4, 2) if quick else WorkspaceSpec(28, 10))
    shutil.copytree(generated.root / "src", root / "src" / "generated", symlinks=True)
    return root, count + len(generated.packages)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/noop.py", description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--project-venv", type=Path, default=DEFAULT_PROJECT_VENV)
    parser.add_argument("--colcon-venv", type=Path, default=DEFAULT_COLCON_VENV)
    parser.add_argument("--work-dir", type=Path,
                        default=Path.home() / ".cache" / "wsbuild-bench" / "noop")
    args = parser.parse_args(argv)
    log = Log()
    tools = setup_tools(args.project_venv, args.colcon_venv, log)
    if tools is None:
        return 2
    started = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    work = args.work_dir.resolve()
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    bench = NoopBench(tools, work, 5 if args.quick else 10, log)
    mixed = generate_workspace(work / "mixed", WorkspaceSpec(6, 2) if args.quick
                               else WorkspaceSpec(30, 6)).root
    bench.noop("mixed 36 packages" if not args.quick else "mixed 8 packages", mixed,
               "≤ 100 ms, ≥ 200×", colcon_runs=1 if args.quick else 2, full_target="≤ 200 ms")
    real = real_shaped(work / "real", quick=args.quick)
    bench.noop(f"{real[1]} packages shaped like real code", real[0], "≤ 150 ms",
               full_target="≤ 300 ms")
    corpus = work / "corpus"
    shutil.copytree(CORPUS, corpus / "src", symlinks=True)
    bench.noop("upstream-pattern corpus", corpus, "≤ 120 ms")
    many = generate_workspace(work / "many", WorkspaceSpec(100 if args.quick else 1000)).root
    bench.noop(f"{100 if args.quick else 1000} synthetic packages", many, "≤ 400 ms")
    clean_outputs(many)
    bench.listing(many, colcon_runs=2 if args.quick else 3)
    bench.version(mixed)
    bench.notes += bench.importtime(mixed, replayed=False)
    bench.notes += bench.importtime(mixed, replayed=True)
    command = "python benchmarks/noop.py" + (" --quick" if args.quick else "")
    section = render(bench, machine_details(tools), command, started, args.quick)
    print(section)
    if not args.quick:
        write_section(DOCS, BEGIN, END, section)
        log(f"wrote {DOCS}")
    return 0


if __name__ == "__main__":
    start = time.monotonic()
    code = main()
    print(f"({time.monotonic() - start:.0f} s)", file=sys.stderr)
    raise SystemExit(code)
