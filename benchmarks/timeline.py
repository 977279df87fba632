"""The benchmark timelines: wsbuild's side from `timings.json` and colcon's from its
`log/<run>/events.log`, per-package phases drawn by the product's own drawing
(`wsbuild/engine/timeline.py`, which also draws every run's report), and their totals."""

from __future__ import annotations

import ast
import json
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

from wsbuild.engine.timeline import Bar, Timeline, phase_of, render_svg

__all__ = ["Bar", "Timeline", "colcon_timeline", "phase_totals", "render_svg",
           "wsbuild_timeline", "write_svg"]


def timeline_from_timings(data: Mapping[str, object], title: str) -> Timeline:
    """A timeline from wsbuild's `timings.json` content: waiting, then each step's phase."""
    bars = []
    for p in data["packages"]:  # type: ignore[attr-defined]
        spans: list[tuple[str, float, float]] = []
        if p["started"] > p["ready"]:
            spans.append(("waiting", p["ready"], p["started"]))
        spans += [(phase_of(label), start, end) for label, start, end in p["phases"]]
        bars.append(Bar(p["package"], tuple(spans)))
    return Timeline(title, tuple(bars), float(data["wall_seconds"]))  # type: ignore[arg-type]


def write_svg(path: Path, timelines: Sequence[Timeline]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(render_svg(timelines), encoding="utf-8")


def phase_totals(timeline: Timeline) -> Mapping[str, float]:
    """Seconds per phase summed over packages."""
    totals: dict[str, float] = {}
    for bar in timeline.bars:
        for phase, start, end in bar.spans:
            totals[phase] = totals.get(phase, 0.0) + max(0.0, end - start)
    return totals


def wsbuild_timeline(timings_json: Path, title: str) -> Timeline:
    return timeline_from_timings(json.loads(timings_json.read_text()), title)


_EVENT = re.compile(r"^\[(?P<t>[0-9.]+)\] \((?P<pkg>[^)]+)\) (?P<kind>\w+): (?P<data>.*)$")


def colcon_timeline(events_log: Path, title: str) -> Timeline:
    """Phases from colcon's JobQueued/JobStarted/JobProgress/JobEnded events."""
    depends: dict[str, list[str]] = {}
    started: dict[str, float] = {}
    ended: dict[str, float] = {}
    marks: dict[str, list[tuple[str, float]]] = {}
    last = 0.0
    for line in events_log.read_text(errors="replace").splitlines():
        match = _EVENT.match(line)
        if not match or match["pkg"] == "-":
            continue
        t, pkg, kind = float(match["t"]), match["pkg"], match["kind"]
        last = max(last, t)
        if kind == "JobQueued":
            deps = re.search(r"'dependencies': OrderedDict\(\[(.*)\]\)", match["data"])
            depends[pkg] = re.findall(r"\('([^']+)', '", deps.group(1)) if deps else []
        elif kind == "JobStarted":
            started[pkg] = t
        elif kind == "JobProgress":
            try:
                progress = ast.literal_eval(match["data"]).get("progress", "")
            except (ValueError, SyntaxError):
                continue
            marks.setdefault(pkg, []).append((str(progress), t))
        elif kind == "JobEnded":
            ended[pkg] = t
    bars = []
    for pkg in sorted(started, key=lambda n: started[n]):
        end = ended.get(pkg, last)
        ready = max((ended[d] for d in depends.get(pkg, []) if d in ended), default=0.0)
        spans: list[tuple[str, float, float]] = []
        if started[pkg] > ready:
            spans.append(("waiting", ready, started[pkg]))
        points = marks.get(pkg, [])
        first = points[0][1] if points else end
        if first > started[pkg]:
            spans.append(("other", started[pkg], first))
        for index, (label, t) in enumerate(points):
            nxt = points[index + 1][1] if index + 1 < len(points) else end
            spans.append((phase_of(label), t, nxt))
        bars.append(Bar(pkg, tuple(spans)))
    return Timeline(title, tuple(bars), last)
