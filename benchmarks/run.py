"""Side-by-side benchmark of wsbuild against colcon on generated workspaces (see benchmarks/README.md)."""

from __future__ import annotations

import argparse
import datetime
import json
import os
import shlex
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

if __package__ in (None, ""):
    # `python benchmarks/run.py`: make `benchmarks.*` importable like `python -m benchmarks.run`
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.generate import GeneratedWorkspace, WorkspaceSpec, generate_workspace
from benchmarks.measure import (
    CommandFailed,
    Measurement,
    clean_outputs,
    empty_discarded,
    repeat,
    run_timed,
    source_command,
    sourced_prefixes,
)
from benchmarks.tools import (
    DEFAULT_COLCON_VENV,
    DEFAULT_PROJECT_VENV,
    REPO,
    Log,
    Tools,
    machine_details,
    setup_tools,
)

SCENARIOS = ("mixed", "py200", "list1000", "scaling")
DOCS = REPO / "docs" / "benchmarks.md"


@dataclass(frozen=True, slots=True)
class Sizes:
    mixed: tuple[int, int]
    py: int
    listing: int
    scaling: tuple[int, ...]
    #: repeats of the short measurements (no-op, list, source) and of the edit
    repeats: int
    edits: int
    #: colcon's no-op rebuild of the mixed workspace is ~16 s: repeated fewer times
    colcon_noop_repeats: int


FULL = Sizes(mixed=(30, 6), py=200, listing=1000, scaling=(50, 200, 1000), repeats=5, edits=3,
             colcon_noop_repeats=3)
QUICK = Sizes(mixed=(6, 2), py=20, listing=100, scaling=(10, 20, 100), repeats=3, edits=2,
              colcon_noop_repeats=2)


@dataclass(slots=True)
class Suite:
    """What was measured for one tool on one workspace (absent keys were not measured)."""

    tool: str
    workspace: GeneratedWorkspace
    results: dict[str, Measurement] = field(default_factory=dict)
    #: sanity facts shown under the tables (packages rebuilt, prefixes after sourcing...)
    facts: dict[str, object] = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)


class Bench:
    """Runs the suites; knows both tools, the work directory and the log file."""

    def __init__(self, tools: Tools, work_dir: Path, sizes: Sizes, log: Log) -> None:
        self.tools = tools
        self.work_dir = work_dir
        self.sizes = sizes
        self.log = log
        self.log_file = work_dir / "bench.log"
        self.cpus = os.cpu_count() or 1
        self._suites: dict[tuple[str, str], Suite] = {}

    # ------------------------------------------------------------------ workspaces

    def workspace(self, spec: WorkspaceSpec, tool: str) -> GeneratedWorkspace:
        """A fresh copy of the generated workspace for `tool` (same seed: identical sources)."""
        name = f"py{spec.python_packages}-cmake{spec.cmake_packages}-{tool}"
        root = self.work_dir / name
        clean_outputs(root)
        # the edit scenario changed a module: regenerate rewrites it (unchanged files keep mtimes)
        return generate_workspace(root, spec)

    def command(self, tool: str, *args: str) -> tuple[list[str], dict[str, str]]:
        if tool == "wsbuild":
            return self.tools.wsbuild_cmd(*args), self.tools.wsbuild_env
        return self.tools.colcon_cmd(*args), self.tools.colcon_env

    # ------------------------------------------------------------------ one suite

    def suite(self, spec: WorkspaceSpec, tool: str, *, full: int = 1, noop: int = 0,
              edits: int = 0, source: int = 0, listing: int = 0) -> Suite:
        """Measure `tool` on a fresh workspace: list, `full` full builds (from clean), no-op
        rebuilds, edits of a leaf package, sourcing install/setup.bash."""
        key = (f"{spec.python_packages}+{spec.cmake_packages}", tool)
        ws = self.workspace(spec, tool)
        suite = Suite(tool=tool, workspace=ws)
        self._suites[key] = suite
        total = len(ws.packages)
        label = f"{tool} on {spec.python_packages} ament_python + {spec.cmake_packages} ament_cmake"
        if listing:
            self.log(f"{label}: list x{listing}")
            cmd, env = self.command(tool, "list")
            m = repeat(cmd, listing, cwd=ws.root, env=env, log_file=self.log_file)
            suite.results["list"] = m
            listed = len(m.last.output.strip().splitlines())
            suite.facts["packages listed"] = listed
            if listed != total:
                suite.problems.append(f"`{tool} list` printed {listed} lines for {total} packages")
        if not full:
            return suite
        self.log(f"{label}: full build x{full}")
        cmd, env = self.command(tool, "build")
        m = Measurement()
        for _ in range(full):
            clean_outputs(ws.root)
            m.samples.append(run_timed(cmd, cwd=ws.root, env=env, log_file=self.log_file))
        suite.results["full"] = m
        suite.facts["built in full build"] = len(m.last.rebuilt)
        missing = [p.name for p in ws.packages
                   if not (ws.root / "install" / p.name / "share" / p.name / "package.xml").is_file()]
        if missing:
            suite.problems.append(f"full build: {len(missing)} packages without "
                                  f"install/<pkg>/share/<pkg>/package.xml, e.g. {missing[:3]}")
        if noop:
            self.log(f"{label}: no-op rebuild x{noop}")
            m = repeat(cmd, noop, cwd=ws.root, env=env, log_file=self.log_file)
            suite.results["noop"] = m
            suite.facts["rebuilt in no-op"] = sorted({len(s.rebuilt) for s in m.samples})
        if edits:
            self._edit(suite, cmd, env, edits, label)
        if source:
            self.log(f"{label}: source install/setup.bash x{source}")
            m = repeat(source_command(ws.root), source, cwd=ws.root, env=self.tools.shell_env,
                       log_file=self.log_file)
            suite.results["source"] = m
            prefixes = sourced_prefixes(ws.root, self.tools.shell_env)
            in_ws = [p for p in prefixes if p.startswith(str(ws.root))]
            suite.facts["AMENT_PREFIX_PATH entries after sourcing (workspace/all)"] = (
                f"{len(in_ws)}/{len(prefixes)}")
        return suite

    def _edit(self, suite: Suite, cmd: list[str], env: dict[str, str], edits: int,
              label: str) -> None:
        ws = suite.workspace
        leaf = ws.leaves()[-1]
        module = ws.module_of(leaf)
        original = module.read_text(encoding="utf-8")
        self.log(f"{label}: edit {leaf}/{leaf}/node.py, rebuild x{edits}")
        m = Measurement()
        for number in range(1, edits + 1):
            marker = f"(edit {number} at {time.time():.0f})"
            module.write_text(original.replace(".')", f". {marker}')"), encoding="utf-8")
            sample = run_timed(cmd, cwd=ws.root, env=env, log_file=self.log_file)
            m.samples.append(sample)
            installed = sorted((ws.root / "install" / leaf).glob(f"lib/python3*/site-packages/{leaf}/node.py"))
            if not installed or marker not in installed[0].read_text(encoding="utf-8"):
                suite.problems.append(f"edit {number}: the installed {leaf}/node.py does not "
                                      "have the edit")
        suite.results["edit"] = m
        rebuilt = sorted({name for s in m.samples for name in s.rebuilt})
        suite.facts["rebuilt after editing a leaf"] = (
            rebuilt if len(rebuilt) <= 3 else f"{len(rebuilt)} packages")
        if suite.tool == "wsbuild" and rebuilt != [leaf]:
            suite.problems.append(f"edit of {leaf}: rebuilt {rebuilt[:5]}"
                                  f"{'...' if len(rebuilt) > 5 else ''}, expected only {leaf}")

    def suites(self) -> dict[tuple[str, str], Suite]:
        return self._suites


# ---------------------------------------------------------------------------- tables


@dataclass(frozen=True, slots=True)
class Row:
    scenario: str
    colcon: Measurement | None
    wsbuild: Measurement | None
    target: str
    #: True/False when both sides were measured, None otherwise
    met: bool | None
    note: str = ""

    @property
    def ratio(self) -> float | None:
        if self.colcon is None or self.wsbuild is None or self.wsbuild.median <= 0:
            return None
        return self.colcon.median / self.wsbuild.median


def _seconds(value: float) -> str:
    if value >= 10:
        return f"{value:.1f} s"
    if value >= 1:
        return f"{value:.2f} s"
    if value >= 0.01:
        return f"{value * 1000:.0f} ms"
    return f"{value * 1000:.1f} ms" if value >= 0.001 else f"{value * 1e6:.0f} µs"


#: other processes taking more than this share of the CPUs during a run mark its cell with †
NOISY = 0.10


def _cell(m: Measurement | None) -> str:
    if m is None:
        return "–"
    runs = f" (median of {m.runs})" if m.runs > 1 else ""
    noisy = " †" if m.contention > NOISY else ""
    return _seconds(m.median) + runs + noisy


def _ratio_target(colcon: Measurement | None, wsbuild: Measurement | None,
                  factor: float) -> bool | None:
    if colcon is None or wsbuild is None:
        return None
    return colcon.median / wsbuild.median >= factor


def main_rows(bench: Bench) -> list[Row]:
    s = bench.sizes
    rows: list[Row] = []
    suites = bench.suites()

    def get(key: str, tool: str, what: str) -> Measurement | None:
        suite = suites.get((key, tool))
        return suite.results.get(what) if suite else None

    mixed = f"{s.mixed[0]}+{s.mixed[1]}"
    mixed_label = f"{s.mixed[0]} ament_python + {s.mixed[1]} ament_cmake"
    py = f"{s.py}+0"
    listing = f"{s.listing}+0"
    for what, label, factor in (("full", "full build", 4), ("noop", "no-op rebuild", 50)):
        c, w = get(mixed, "colcon", what), get(mixed, "wsbuild", what)
        rows.append(Row(f"{label}, {mixed_label}", c, w, f"≥ {factor}× faster",
                        _ratio_target(c, w, factor)))
    for what, label, factor in (("full", "full build", 10), ("noop", "no-op rebuild", 100)):
        c, w = get(py, "colcon", what), get(py, "wsbuild", what)
        rows.append(Row(f"{label}, {s.py} ament_python", c, w, f"≥ {factor}× faster",
                        _ratio_target(c, w, factor)))
    c, w = get(mixed, "colcon", "edit"), get(mixed, "wsbuild", "edit")
    met = None
    note = ""
    suite_w = suites.get((mixed, "wsbuild"))
    suite_c = suites.get((mixed, "colcon"))
    if w is not None:
        rebuilt = sorted({n for smp in w.samples for n in smp.rebuilt})
        met = rebuilt == [suite_w.workspace.leaves()[-1]] and w.median < 1.0  # type: ignore[union-attr]
        note = f"wsbuild rebuilt {len(rebuilt)}"
    if c is not None and suite_c is not None:
        note += f"{', ' if note else ''}colcon rebuilt {len(c.last.rebuilt)}"
    rows.append(Row(f"edit one .py in a leaf package, rebuild ({mixed_label})", c, w,
                    "only that package, < 1 s", met, note))
    c, w = get(py, "colcon", "source"), get(py, "wsbuild", "source")
    rows.append(Row(f"`source install/setup.bash`, {s.py} packages", c, w, "≥ 5× faster",
                    _ratio_target(c, w, 5)))
    c, w = get(listing, "colcon", "list"), get(listing, "wsbuild", "list")
    rows.append(Row(f"`list` on {s.listing} packages", c, w, "≥ 10× faster",
                    _ratio_target(c, w, 10)))
    return [r for r in rows if r.colcon is not None or r.wsbuild is not None]


def _cpu(r: Row) -> str:
    if r.colcon is None or r.wsbuild is None:
        return "–"
    ratio = r.colcon.cpu_median / r.wsbuild.cpu_median if r.wsbuild.cpu_median > 0 else 0
    return (f"{_seconds(r.colcon.cpu_median)} / {_seconds(r.wsbuild.cpu_median)} "
            f"({ratio:.1f}×)")


def render_main(rows: Sequence[Row]) -> list[str]:
    lines = ["| scenario | colcon | wsbuild | ratio | target | met | CPU colcon / wsbuild |",
             "|---|---:|---:|---:|---|---|---:|"]
    for r in rows:
        ratio = f"{r.ratio:.1f}×" if r.ratio is not None else "–"
        met = {True: "yes", False: "**no**", None: "–"}[r.met]
        note = f" ({r.note})" if r.note else ""
        lines.append(f"| {r.scenario} | {_cell(r.colcon)} | {_cell(r.wsbuild)} | {ratio} | "
                     f"{r.target} | {met}{note} | {_cpu(r)} |")
    return lines


def load_range(bench: Bench) -> tuple[float, float] | None:
    loads = [s.load for suite in bench.suites().values() for m in suite.results.values()
             for s in m.samples]
    return (min(loads), max(loads)) if loads else None


SCALING_METRICS = (
    ("full", "full build"),
    ("noop", "no-op rebuild"),
    ("edit", "edit one leaf .py, rebuild"),
    ("source", "`source install/setup.bash`"),
    ("list", "`wsbuild list`"),
)


def render_scaling(bench: Bench) -> list[str]:
    suites = bench.suites()
    sizes = [n for n in bench.sizes.scaling if (f"{n}+0", "wsbuild") in suites]
    if len(sizes) < 2:
        return []
    first, last = sizes[0], sizes[-1]
    lines = ["| wsbuild | " + " | ".join(f"{n} pkgs" for n in sizes)
             + f" | {last} vs {first} pkgs ({last / first:.0f}× the packages) |",
             "|---|" + "---:|" * (len(sizes) + 1)]
    for key, label in SCALING_METRICS:
        found = [suites[(f"{n}+0", "wsbuild")].results.get(key) for n in sizes]
        if all(m is None for m in found):
            continue
        cells = [_seconds(m.median) if m else "–" for m in found]
        growth = (f"{found[-1].median / found[0].median:.1f}×"
                  if found[0] is not None and found[-1] is not None else "–")
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {growth} |")
    return lines


def render_facts(bench: Bench) -> list[str]:
    lines = []
    def order(item: tuple[tuple[str, str], Suite]) -> tuple[int, int, str]:
        (key, tool), _ = item
        python, cmake = key.split("+")
        return int(python) + int(cmake), int(cmake), tool

    for (key, tool), suite in sorted(bench.suites().items(), key=order):
        facts = "; ".join(f"{k}: {v}" for k, v in suite.facts.items())
        if facts:
            lines.append(f"- {tool}, {key.replace('+', ' ament_python + ')} ament_cmake: {facts}")
        noisy = [f"{what} {m.contention:.0%}" for what, m in suite.results.items()
                 if m.contention > NOISY]
        if noisy:
            lines.append(f"- {tool}, {key.replace('+', ' ament_python + ')} ament_cmake: "
                         f"other processes' share of the CPUs (worst run): {', '.join(noisy)}")
        for problem in suite.problems:
            lines.append(f"- **problem** ({tool}, {key}): {problem}")
    return lines


def load_note(bench: Bench) -> list[str]:
    loads = load_range(bench)
    if loads is None:
        return []
    text = (f"1-minute load average when the timed commands started: {loads[0]:.2f} to "
            f"{loads[1]:.2f} on {bench.cpus} CPUs.")
    if any(m.contention > NOISY for suite in bench.suites().values()
           for m in suite.results.values()):
        text = (f"† other processes (not the timed command) used more than {NOISY:.0%} of the "
                "CPUs during at least one of the runs (from /proc/stat; see Checks): that time "
                "is less trustworthy, the CPU column less affected. " + text)
    return [text, ""]


def render_report(bench: Bench, details: dict[str, str], command: str, started: str,
                  elapsed: float, quick: bool) -> str:
    out = [
        "# wsbuild vs colcon benchmark",
        "",
        f"Generated by `{command}` on {started} (took {elapsed / 60:.1f} min)."
        + (" **Quick mode: small workspaces, not comparable with the targets.**" if quick else ""),
        "",
        "Machine: " + "; ".join(f"{k}: {v}" for k, v in details.items()) + ".",
        "",
        "Times are wall-clock seconds of the real command (`<project venv>/bin/wsbuild`, "
        "`<colcon venv>/bin/colcon`), median of the repeats shown; a full build starts without "
        "build/, install/ and log/. ratio = colcon / wsbuild. CPU is user + system time of the "
        "command and all its children (less sensitive to other load on the machine).",
        "",
        *load_note(bench),
        *render_main(main_rows(bench)),
        "",
    ]
    scaling = render_scaling(bench)
    if scaling:
        out += ["## How wsbuild grows with the workspace (ament_python only)", "", *scaling, ""]
    facts = render_facts(bench)
    if facts:
        out += ["## Checks", "", *facts, ""]
    return "\n".join(out)


#: docs/benchmarks.md: the report above this line is regenerated, the notes below it are kept
NOTES_MARKER = "<!-- end of generated results: everything below is kept by benchmarks/run.py -->"


def write_docs_file(path: Path, report: str) -> None:
    """Replace the generated part of `path`, keeping the hand-written notes after the marker."""
    notes = ""
    if path.is_file():
        text = path.read_text(encoding="utf-8")
        if NOTES_MARKER in text:
            notes = text.split(NOTES_MARKER, 1)[1]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(report.rstrip("\n") + "\n\n" + NOTES_MARKER + (notes or "\n"),
                    encoding="utf-8")


# ------------------------------------------------------------------------------ main


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python benchmarks/run.py",
        description="Generate synthetic workspaces, build them with wsbuild and colcon, "
                    "print the comparison (and write docs/benchmarks.md on a full run).",
    )
    parser.add_argument("--quick", action="store_true",
                        help="small workspaces and fewer repeats: a smoke run (about a minute)")
    parser.add_argument("--scenarios", nargs="+", choices=SCENARIOS, default=list(SCENARIOS),
                        metavar="NAME",
                        help=f"which to run (default: all): {', '.join(SCENARIOS)}")
    parser.add_argument("--project-venv", type=Path, default=DEFAULT_PROJECT_VENV,
                        help="the venv with wsbuild and the ROS wheels (default: %(default)s)")
    parser.add_argument("--colcon-venv", type=Path, default=DEFAULT_COLCON_VENV,
                        help="colcon's venv, created if missing (default: %(default)s)")
    parser.add_argument("--work-dir", type=Path,
                        default=Path.home() / ".cache" / "wsbuild-bench" / "workspaces",
                        help="where the generated workspaces go (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the dependency DAGs")
    docs = parser.add_mutually_exclusive_group()
    docs.add_argument("--docs", dest="docs", action="store_true", default=None,
                      help="write docs/benchmarks.md (default: only for a full run of everything)")
    docs.add_argument("--no-docs", dest="docs", action="store_false")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the raw numbers")
    return parser.parse_args(argv)


def run(args: argparse.Namespace, bench: Bench) -> None:
    s = bench.sizes
    chosen = set(args.scenarios)
    if "mixed" in chosen:
        spec = WorkspaceSpec(s.mixed[0], s.mixed[1], seed=args.seed)
        # the full build is close to its target: repeated (colcon's takes ~18 s)
        bench.suite(spec, "colcon", full=2, noop=s.colcon_noop_repeats, edits=1)
        bench.suite(spec, "wsbuild", full=3, noop=s.repeats, edits=s.edits)
    if "py200" in chosen:
        spec = WorkspaceSpec(s.py, seed=args.seed)
        # colcon's 200-package builds are the slow part: once each
        bench.suite(spec, "colcon", noop=1, source=s.repeats)
        bench.suite(spec, "wsbuild", noop=s.repeats, edits=s.edits, source=s.repeats,
                    listing=s.repeats)
    if "list1000" in chosen:
        spec = WorkspaceSpec(s.listing, seed=args.seed)
        bench.suite(spec, "colcon", full=0, listing=s.repeats)
        if "scaling" not in chosen:
            bench.suite(spec, "wsbuild", full=0, listing=s.repeats)
    if "scaling" in chosen:
        for n in s.scaling:
            if (f"{n}+0", "wsbuild") in bench.suites():
                continue  # measured above with everything the scaling table shows
            bench.suite(WorkspaceSpec(n, seed=args.seed), "wsbuild", noop=s.repeats,
                        edits=s.edits, source=s.repeats, listing=s.repeats)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    log = Log()
    sizes = QUICK if args.quick else FULL
    started = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    t0 = time.monotonic()
    tools = setup_tools(args.project_venv, args.colcon_venv, log)
    if tools is None:
        return 2
    details = machine_details(tools)
    log("machine: " + "; ".join(f"{k}: {v}" for k, v in details.items()))
    args.work_dir.mkdir(parents=True, exist_ok=True)
    bench = Bench(tools, args.work_dir.resolve(), sizes, log)
    bench.log_file.write_text("")
    log(f"every command's output: {bench.log_file}")
    try:
        run(args, bench)
    except CommandFailed as exc:
        print(f"benchmark aborted: {exc}", file=sys.stderr)
        return 1
    finally:
        empty_discarded(bench.work_dir)
    elapsed = time.monotonic() - t0
    command = "python benchmarks/run.py" + (" " + shlex.join(argv if argv is not None
                                                           else sys.argv[1:])).rstrip()
    report = render_report(bench, details, command.strip(), started, elapsed, args.quick)
    print(report)
    write_docs = args.docs if args.docs is not None else (
        not args.quick and set(args.scenarios) == set(SCENARIOS))
    if write_docs:
        write_docs_file(DOCS, report)
        log(f"wrote {DOCS}")
    if args.json:
        raw = {f"{tool} {key}": {what: m.as_dict() for what, m in suite.results.items()}
               | {"facts": suite.facts, "problems": suite.problems}
               for (key, tool), suite in bench.suites().items()}
        args.json.write_text(json.dumps({"machine": details, "results": raw}, indent=2,
                                        default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
