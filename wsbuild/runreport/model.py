"""A run as its report shows it, read from the run's log directory alone: `report.json`,
`timings.json`, each package's `command.log` (why it was built, what the build cache did),
`up_to_date.log`, `ccache_stats.log` (compiler-cache hits per package) and the end of a failed
package's `stdout_stderr.log`."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.engine.logs import COMMAND_LOG
from wsbuild.engine.timeline import Bar, phase_of
from wsbuild.engine.timing_files import bound_text, critical_chain
from wsbuild.engine.timings import TIMINGS_JSON
from wsbuild.runreport.report_json import REPORT_JSON
from wsbuild.words import plural

#: lines of a failed package's log shown in the report
TAIL_LINES = 15
CCACHE_STATS = "ccache_stats.log"
#: the line before a package's compiles in CCACHE_STATS (as builder/resources/compiler_cache.py writes it)
_CCACHE_PACKAGE = "## package "
_CCACHE_HITS = {"direct_cache_hit", "preprocessed_cache_hit"}
FAILED_OUTCOMES = ("failed", "interrupted")


class NoReport(Exception):
    """The directory is not a run that wrote report data."""


@dataclass(frozen=True, slots=True)
class PackageRow:
    """One package's row of the run report."""

    name: str
    build_type: str
    outcome: str
    seconds: float
    reason: str
    compiler_cache: str
    artifact_cache: str
    log_dir: str | None
    message: str = ""
    reproduce: str = ""
    #: the last lines of a failed package's log
    tail: tuple[str, ...] = ()
    restored: bool = False
    critical: bool = False
    waiting: float = 0.0
    #: seconds per drawn phase (configure, build, install, test, ...)
    phases: Mapping[str, float] = field(default_factory=dict)
    tests: Mapping[str, object] | None = None
    #: its processes' peak resident memory (bytes; None: not measured), and the seconds it
    #: waited for memory (to start, and before its steps)
    memory_peak: int | None = None
    memory_wait: float = 0.0

    @property
    def failed(self) -> bool:
        return self.outcome in FAILED_OUTCOMES


@dataclass(frozen=True, slots=True)
class RunReport:
    """What the HTML report of a run shows."""

    run_dir: Path
    record: Mapping[str, object]
    timings: Mapping[str, object]
    packages: tuple[PackageRow, ...]
    bars: tuple[Bar, ...]
    critical_path: tuple[str, ...]
    #: the compiler cache's hits and misses, the sum of the package rows' (None: no ccache
    #: stats log, e.g. sccache: the run's own counts in `record` are shown)
    compiled: tuple[int, int] | None = None
    #: the critical path with the seconds each of its packages ran
    chain: tuple[tuple[str, float], ...] = ()

    @property
    def verb(self) -> str:
        return str(self.record.get("verb", "build"))

    @property
    def memory(self) -> Mapping[str, object] | None:
        """What the run used of its memory budget (timings.json's `memory`; None: none)."""
        value = self.timings.get("memory")
        return value if isinstance(value, Mapping) else None

    @property
    def wall(self) -> float:
        return float(self.timings.get("wall_seconds", 0.0))  # type: ignore[arg-type]

    @property
    def failed(self) -> list[PackageRow]:
        return [p for p in self.packages if p.failed]


def _read_json(path: Path) -> dict[str, object] | None:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def load_run(run_dir: Path) -> RunReport:
    """Everything the report shows, from `run_dir` (raises NoReport without report.json)."""
    run_dir = run_dir.resolve()  # log/latest is the run it points to
    record = _read_json(run_dir / REPORT_JSON)
    if record is None:
        raise NoReport(f"{run_dir} holds no {REPORT_JSON}")
    timings = _read_json(run_dir / TIMINGS_JSON) or {}
    entries: list[dict[str, object]] = list(record.get("packages", []))  # type: ignore[arg-type]
    times = {str(p["package"]): p for p in timings.get("packages", [])}  # type: ignore[union-attr]
    chain = critical_chain((n, float(t["ready"]), float(t["started"]), float(t["finished"]))
                           for n, t in times.items())
    critical = [name for name, _ in chain]
    counts = compiler_cache_counts(run_dir / CCACHE_STATS, entries)
    compiler = {name: compiler_cache_text(*tally) for name, tally in counts.items()}
    cache_on = str(record.get("artifact_cache", "off")).startswith("local")
    up_to_date = _up_to_date_reasons(run_dir)
    memory = timings.get("memory")
    by_package = memory.get("packages") if isinstance(memory, dict) else None
    used: Mapping[str, Mapping[str, object]] = by_package if isinstance(by_package, dict) else {}
    rows = []
    for entry in entries:
        name = str(entry["name"])
        log_text = _command_log(run_dir, entry.get("log_dir"))
        timing = times.get(name)
        rows.append(PackageRow(
            name=name, build_type=str(entry.get("build_type", "")),
            outcome=str(entry["outcome"]), seconds=float(entry.get("seconds", 0.0)),
            reason=_reason(entry, log_text, up_to_date, record.get("verb") == "test"),
            compiler_cache=compiler.get(name, ""),
            artifact_cache=_artifact_cache(entry, log_text, cache_on),
            log_dir=entry.get("log_dir"),  # type: ignore[arg-type]
            message=str(entry.get("message", "")), reproduce=str(entry.get("reproduce", "")),
            tail=_tail(run_dir, entry) if entry["outcome"] in FAILED_OUTCOMES else (),
            restored=bool(entry.get("restored")), critical=name in critical,
            waiting=float(timing["idle"]) if timing else 0.0,
            phases=_phase_seconds(timing) if timing else {},
            tests=entry.get("tests"),  # type: ignore[arg-type]
            memory_peak=_int(used.get(name, {}).get("peak")),
            memory_wait=float(used.get(name, {}).get("waited", 0.0) or 0.0),  # type: ignore
        ))
    packages = tuple(rows)
    compiled = (sum(h for h, _ in counts.values()), sum(m for _, m in counts.values())) \
        if (run_dir / CCACHE_STATS).is_file() else None
    return RunReport(run_dir, record, timings, packages, _bars(packages, times),
                     tuple(critical), compiled, tuple(chain))


def _int(value: object) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def _command_log(run_dir: Path, log_dir: object) -> str:
    if not log_dir:
        return ""
    try:
        return (run_dir / str(log_dir) / COMMAND_LOG).read_text(errors="replace")
    except OSError:
        return ""


def _up_to_date_reasons(run_dir: Path) -> dict[str, str]:
    try:
        lines = (run_dir / "up_to_date.log").read_text(errors="replace").splitlines()
    except OSError:
        return {}
    reasons = {}
    for line in lines:
        name, _, why = line.partition(": ")
        reasons[name] = why
    return reasons


def _reason(entry: Mapping[str, object], log_text: str, up_to_date: Mapping[str, str],
            testing: bool) -> str:
    outcome = entry["outcome"]
    if testing:
        tests = entry.get("tests")
        if isinstance(tests, Mapping) and tests.get("cached"):
            return ("cached: the result of an earlier run, shown as it was (nothing its tests "
                    "observe changed)")
        return "" if outcome != "not run" else "not run (--abort-on-error or Ctrl-C)"
    if outcome == "up to date":
        # a package cut off after its dependencies' builds says so in its result
        return up_to_date.get(str(entry["name"])) or str(entry.get("message") or "up to date")
    if outcome == "skipped":
        return "not processed: a package it depends on failed"
    for line in log_text.splitlines():
        if line.startswith("Rebuilding: "):
            return line[len("Rebuilding: "):]
    return ""


def _artifact_cache(entry: Mapping[str, object], log_text: str, enabled: bool) -> str:
    if entry["outcome"] in ("up to date", "skipped") or "tests" in entry:
        return ""
    for line in log_text.splitlines():
        if line.startswith("Restored from the build cache ("):
            return "restored (" + line.split("(", 1)[1].split(",")[0] + ")"
    if not enabled:
        return "off"
    for line in log_text.splitlines():
        if line.startswith("Build cache: "):
            return "miss; not stored: " + line[len("Build cache: "):]
    return "miss; stored" if entry["outcome"] == "finished" else "miss"


def compiler_cache_text(hits: int, misses: int) -> str:
    """`3 hits, 1 miss`: the report's words for compiler-cache counts."""
    return f"{plural(hits, 'hit')}, {plural(misses, 'miss', 'misses')}"


def compiler_cache_counts(stats_log: Path, entries: Sequence[Mapping[str, object]]
                          ) -> dict[str, tuple[int, int]]:
    """(hits, misses) per package from ccache's stats log (`# <source>` then its result
    counters): each package's compiles follow a `## package NAME` line; in a log without
    them (an older run's), a compile is the package's whose source or build directory holds
    the source file. Packages that compiled nothing are left out."""
    try:
        lines = stats_log.read_text(errors="replace").splitlines()
    except OSError:
        return {}
    names = {str(e["name"]) for e in entries}
    roots = sorted(((str(e[key]).rstrip("/") + "/", str(e["name"]))
                    for e in entries for key in ("path", "build_dir") if e.get(key)),
                   key=lambda item: -len(item[0]))
    counts: dict[str, list[int]] = {}
    package: str | None = None
    owner: str | None = None
    for line in lines:
        if line.startswith(_CCACHE_PACKAGE):
            package = line[len(_CCACHE_PACKAGE):].strip()
            package = package if package in names else None
        elif line.startswith("# "):
            source = line[2:].strip()
            owner = package or next((n for root, n in roots if source.startswith(root)), None)
        elif owner is not None:
            word = line.strip()
            tally = counts.setdefault(owner, [0, 0])
            if word in _CCACHE_HITS:
                tally[0] += 1
            elif word == "cache_miss":
                tally[1] += 1
    return {name: (hits, misses) for name, (hits, misses) in sorted(counts.items())
            if hits or misses}


def _tail(run_dir: Path, entry: Mapping[str, object]) -> tuple[str, ...]:
    if not entry.get("log_dir"):
        return ()
    try:
        text = (run_dir / str(entry["log_dir"]) / "stdout_stderr.log").read_text(errors="replace")
    except OSError:
        return ()
    return tuple(text.splitlines()[-TAIL_LINES:])


def _phase_seconds(timing: Mapping[str, object]) -> dict[str, float]:
    totals: dict[str, float] = {}
    for label, start, end in timing.get("phases", []):  # type: ignore[attr-defined]
        phase = phase_of(str(label))
        totals[phase] = round(totals.get(phase, 0.0) + float(end) - float(start), 3)
    return totals


def _bars(packages: Sequence[PackageRow], times: Mapping[str, Mapping[str, object]]
          ) -> tuple[Bar, ...]:
    """One bar per package, in the order they started (those never started last)."""
    def order(row: PackageRow) -> tuple[int, float, str]:
        timing = times.get(row.name)
        if timing is None:
            return (1, 0.0, row.name)
        return (0, float(timing["started"]), row.name)  # type: ignore[arg-type]

    bars = []
    for row in sorted(packages, key=order):
        timing = times.get(row.name)
        if timing is None:
            bars.append(Bar(row.name, (), row.critical, note=row.outcome))
            continue
        spans: list[tuple[str, float, float]] = []
        ready, started = float(timing["ready"]), float(timing["started"])  # type: ignore[arg-type]
        if started > ready:
            spans.append(("waiting", ready, started))
        for label, start, end in timing.get("phases", []):  # type: ignore[attr-defined]
            spans.append((phase_of(str(label)), float(start), float(end)))
        spans = _mark_outcome(spans, row)
        bars.append(Bar(row.name, tuple(spans), row.critical))
    return tuple(bars)


def _mark_outcome(spans: list[tuple[str, float, float]], row: PackageRow
                  ) -> list[tuple[str, float, float]]:
    """An up-to-date package's check is drawn as "up to date", a restore as "restored from
    cache", the step a package failed in as "failed"."""
    if row.outcome == "up to date":
        return [("up to date" if p == "check" else p, s, e) for p, s, e in spans]
    if row.restored:
        return [("restored" if p == "check" else p, s, e) for p, s, e in spans]
    if row.failed and spans and spans[-1][0] != "waiting":
        phase, start, end = spans[-1]
        return [*spans[:-1], ("failed", start, end)]
    return spans


def summary_lines(report: RunReport) -> list[str]:
    """An earlier run in a few lines: what came of its packages, its time against the CPU
    limit, its critical path (`wsbuild report` prints these, then the page's path)."""
    record, timings = report.record, report.timings
    lines = [f"Run {report.run_dir.name}: {record.get('command', '')} "
             f"(started {record.get('started', '?')})"]
    by_outcome: dict[str, list[str]] = {}
    for row in report.packages:
        by_outcome.setdefault(row.outcome, []).append(row.name)
    if report.verb == "test":
        main, count, done = "", len(report.packages), "tested"
    else:
        main, done = "finished", "finished"
        count = len(by_outcome.get(main, []))
    lines.append(f"Summary: {count} package{'' if count == 1 else 's'} {done} "
                 f"[{report.wall:.2f}s]")
    restored = [p.name for p in report.packages if p.restored]
    if restored:
        lines.append(f"  {len(restored)} restored from cache")
    for outcome, names in sorted(by_outcome.items()):
        if outcome == main:
            continue
        shown = "" if outcome == "up to date" else ": " + " ".join(names)
        lines.append(f"  {len(names)} {outcome}{shown}")
    cpu: Mapping[str, float] = timings.get("cpu_seconds", {})  # type: ignore[assignment]
    if cpu:
        cores = int(timings.get("cores", 1) or 1)  # type: ignore[call-overload]
        lines.append(f"  CPU {float(cpu.get('total', 0.0)):.1f} s on {cores} cores; "
                     + bound_text(report.wall, float(cpu.get("total", 0.0)), cores,
                                  report.chain))
    if report.critical_path:
        lines.append(f"  critical path: {' → '.join(report.critical_path)}")
    for row in report.failed:
        headline = row.message.splitlines()[0] if row.message else row.outcome
        failing: list[Mapping[str, str]] = list((row.tests or {}).get("failing", []))  # type: ignore[call-overload]
        if failing:
            headline = f"{len(failing)} failing test{'' if len(failing) == 1 else 's'}"
        lines.append(f"  failed: {row.name}: {headline}")
        lines += [f"    {case['name']} - {case.get('headline', '')}" for case in failing]
        if row.log_dir:
            lines.append(f"    log: {report.run_dir / row.log_dir}")
    return lines
