"""Per-package timelines of a build as an SVG written by hand: one bar per package over time,
coloured by phase (idle waiting for a worker, configure, build, install, other).

Sources: wsbuild's `log/<run>/timings.json` and colcon's `log/<run>/events.log`.
"""

from __future__ import annotations

import ast
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import escape

PHASE_COLOURS = {
    "idle": "#d9d9d9",
    "configure": "#4e79a7",
    "build": "#f28e2b",
    "install": "#59a14f",
    "other": "#9c755f",
}
#: wsbuild step labels and colcon progress names → the phases drawn
_PHASE_OF = {"configure": "configure", "cmake": "configure", "build": "build",
             "install": "install"}


@dataclass(frozen=True, slots=True)
class Bar:
    package: str
    #: (phase, start, end) in seconds since the run started
    spans: tuple[tuple[str, float, float], ...]


@dataclass(frozen=True, slots=True)
class Timeline:
    title: str
    bars: tuple[Bar, ...]
    wall: float


def _phase(label: str) -> str:
    return _PHASE_OF.get(label, "other")


def wsbuild_timeline(timings_json: Path, title: str) -> Timeline:
    data = json.loads(timings_json.read_text())
    bars = []
    for p in data["packages"]:
        spans = []
        if p["started"] > p["ready"]:
            spans.append(("idle", p["ready"], p["started"]))
        spans += [(_phase(label), start, end) for label, start, end in p["phases"]]
        bars.append(Bar(p["package"], tuple(spans)))
    return Timeline(title, tuple(bars), float(data["wall_seconds"]))


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
            spans.append(("idle", ready, started[pkg]))
        points = marks.get(pkg, [])
        first = points[0][1] if points else end
        if first > started[pkg]:
            spans.append(("other", started[pkg], first))
        for index, (label, t) in enumerate(points):
            nxt = points[index + 1][1] if index + 1 < len(points) else end
            spans.append((_phase(label), t, nxt))
        bars.append(Bar(pkg, tuple(spans)))
    return Timeline(title, tuple(bars), last)


def render_svg(timelines: Sequence[Timeline], *, width: int = 960) -> str:
    """One panel per timeline, on a shared time axis, and a legend."""
    row, label_width, margin = 16, 190, 10
    scale_end = max((t.wall for t in timelines), default=1.0) or 1.0
    plot = width - label_width - 2 * margin
    x = lambda seconds: label_width + margin + plot * seconds / scale_end  # noqa: E731
    parts: list[str] = []
    y = margin
    for timeline in timelines:
        parts.append(f'<text x="{margin}" y="{y + 12}" font-weight="bold">'
                     f"{escape(timeline.title)} ({timeline.wall:.0f} s)</text>")
        y += 20
        for bar in timeline.bars:
            parts.append(f'<text x="{label_width}" y="{y + 12}" text-anchor="end">'
                         f"{escape(bar.package)}</text>")
            for phase, start, end in bar.spans:
                if x(end) - x(start) < 0.3:  # invisible: keep the file small
                    continue
                parts.append(f'<rect x="{x(start):.1f}" y="{y + 2}" '
                             f'width="{x(end) - x(start):.1f}" height="{row - 4}" '
                             f'fill="{PHASE_COLOURS[phase]}"><title>{escape(bar.package)} '
                             f"{phase} {start:.1f}-{end:.1f} s</title></rect>")
            y += row
        y += 10
    # time axis
    step = _tick_step(scale_end)
    parts.append(f'<line x1="{x(0):.1f}" y1="{y}" x2="{x(scale_end):.1f}" y2="{y}" '
                 'stroke="#333"/>')
    tick = 0.0
    while tick <= scale_end + 1e-9:
        parts.append(f'<line x1="{x(tick):.1f}" y1="{y}" x2="{x(tick):.1f}" y2="{y + 4}" '
                     'stroke="#333"/>')
        parts.append(f'<text x="{x(tick):.1f}" y="{y + 16}" text-anchor="middle">'
                     f"{tick:.0f} s</text>")
        tick += step
    y += 26
    legend_x = label_width + margin
    for phase, colour in PHASE_COLOURS.items():
        label = "idle (ready, waiting for a worker)" if phase == "idle" else phase
        parts.append(f'<rect x="{legend_x}" y="{y}" width="12" height="12" fill="{colour}"/>')
        parts.append(f'<text x="{legend_x + 16}" y="{y + 11}">{escape(label)}</text>')
        legend_x += 24 + 7 * len(label)
    height = y + 22
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="11">\n'
            f'<rect width="{width}" height="{height}" fill="white"/>\n'
            + "\n".join(parts) + "\n</svg>\n")


def _tick_step(total: float) -> float:
    for step in (1, 2, 5, 10, 15, 30, 60, 120, 300, 600):
        if total / step <= 12:
            return float(step)
    return 1200.0


def write_svg(path: Path, timelines: Sequence[Timeline]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(render_svg(timelines), encoding="utf-8")


def phase_totals(timeline: Timeline) -> Mapping[str, float]:
    """Seconds per phase summed over packages (for the notes)."""
    totals: dict[str, float] = {}
    for bar in timeline.bars:
        for phase, start, end in bar.spans:
            totals[phase] = totals.get(phase, 0.0) + max(0.0, end - start)
    return totals
