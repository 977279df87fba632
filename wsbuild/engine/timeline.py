"""Drawings of a run, as SVG written by hand: per-job timelines (one row per job, bars coloured
by phase, the critical path outlined) and busy cores over time.

The run report (runreport/) draws one run with these; the compile-heavy benchmark draws
wsbuild's and colcon's cold builds side by side on a shared time axis with the same code.
Same data, same text: no clock, no randomness, numbers rounded to a fixed precision.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from html import escape

#: phase -> (colour, legend text), in legend order
PHASES: dict[str, tuple[str, str]] = {
    "waiting": ("#d9d9d9", "waiting for a worker"),
    "memory": ("#ff9da7", "waiting for memory"),
    "check": ("#bab0ac", "up-to-date check"),
    "configure": ("#4e79a7", "configure"),
    "build": ("#f28e2b", "build"),
    "install": ("#59a14f", "install"),
    "test": ("#76b7b2", "tests"),
    "other": ("#9c755f", "other steps"),
    "restored": ("#b07aa1", "restored from cache"),
    "up to date": ("#a0cbe8", "up to date"),
    "failed": ("#e15759", "failed"),
}
#: step labels (wsbuild's build types, colcon's progress names, test tools) -> phase drawn
_PHASE_OF = {"configure": "configure", "cmake": "configure", "build": "build",
             "install": "install", "pytest": "test", "ctest": "test", "check": "check",
             # engine/memory.py's WAIT_LABEL
             "wait": "memory"}

ROW = 18
LABEL_WIDTH = 200
MARGIN = 10


def phase_of(label: str) -> str:
    """The drawn phase of a step label (`pytest 2/3` is a test too)."""
    if label in PHASES:
        return label
    return _PHASE_OF.get(label.split(" ")[0], "other")


@dataclass(frozen=True, slots=True)
class Bar:
    """One package's bar of the timeline: its phases' spans."""

    package: str
    #: (phase, start, end) in seconds since the run started
    spans: tuple[tuple[str, float, float], ...]
    critical: bool = False
    #: shown after the name when there is no bar (e.g. "not processed")
    note: str = ""


@dataclass(frozen=True, slots=True)
class Timeline:
    """The timeline of a run: a bar per package."""

    title: str
    bars: tuple[Bar, ...]
    wall: float


def _fmt(value: float) -> str:
    return f"{value:.1f}"


def _tick_step(total: float) -> float:
    for step in (0.1, 0.2, 0.5, 1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 1200):
        if total / step <= 12:
            return float(step)
    return 3600.0


def _seconds(value: float) -> str:
    return f"{value:.1f} s" if value < 10 and value != int(value) else f"{value:.0f} s"


def _axis(x0: float, plot: float, scale_end: float, y: int) -> list[str]:
    """A time axis under a plot that starts at x0 and is `plot` wide."""
    parts = [f'<line x1="{_fmt(x0)}" y1="{y}" x2="{_fmt(x0 + plot)}" y2="{y}" stroke="#333"/>']
    step = _tick_step(scale_end)
    count = int(scale_end / step + 1e-9)
    for index in range(count + 1):
        tick = index * step
        x = x0 + plot * tick / scale_end
        parts.append(f'<line x1="{_fmt(x)}" y1="{y}" x2="{_fmt(x)}" y2="{y + 4}" stroke="#333"/>')
        parts.append(f'<text x="{_fmt(x)}" y="{y + 16}" text-anchor="middle">'
                     f"{_seconds(tick)}</text>")
    return parts


def render_svg(timelines: Sequence[Timeline], *, width: int = 960) -> str:
    """One panel per timeline on a shared time axis, then a legend of the phases drawn.
    Each row is a `<g class="row">` (`row critical` on the critical path) holding its name and
    bars; each bar's `<title>` gives the exact times (the browser shows it on hover)."""
    plot = width - LABEL_WIDTH - 2 * MARGIN
    ends = [end for t in timelines for bar in t.bars for _, _, end in bar.spans]
    scale_end = max([*(t.wall for t in timelines), *ends], default=1.0) or 1.0
    x0 = LABEL_WIDTH + MARGIN

    def x(seconds: float) -> float:
        return x0 + plot * max(0.0, seconds) / scale_end

    parts: list[str] = []
    used: list[str] = []
    critical_drawn = False
    y = MARGIN
    for timeline in timelines:
        if timeline.title:
            parts.append(f'<text x="{MARGIN}" y="{y + 12}" font-weight="bold">'
                         f"{escape(timeline.title)} ({_seconds(timeline.wall)})</text>")
            y += 20
        for bar in timeline.bars:
            critical_drawn |= bar.critical
            css = "row critical" if bar.critical else "row"
            parts.append(f'<g class="{css}" data-package="{escape(bar.package)}">')
            label = ("\u2605 " if bar.critical else "") + bar.package
            weight = ' font-weight="bold"' if bar.critical else ""
            parts.append(f'<text x="{LABEL_WIDTH}" y="{y + 13}" text-anchor="end"{weight}>'
                         f"{escape(label)}</text>")
            if bar.note:
                parts.append(f'<text x="{_fmt(x0 + 4)}" y="{y + 13}" fill="#777">'
                             f"{escape(bar.note)}</text>")
            for phase, start, end in bar.spans:
                if phase not in used:
                    used.append(phase)
                # at least a sliver: an up-to-date package's bar must still be visible
                left, span = x(start), max(1.0, x(end) - x(start))
                stroke = ' stroke="#000" stroke-width="1.5"' if bar.critical else ""
                parts.append(
                    f'<rect class="bar" x="{_fmt(left)}" y="{y + 3}" width="{_fmt(span)}" '
                    f'height="{ROW - 6}" fill="{PHASES.get(phase, PHASES["other"])[0]}"{stroke}>'
                    f"<title>{escape(bar.package)}: {escape(phase)} {start:.2f}\u2013{end:.2f} s "
                    f"({end - start:.2f} s)</title></rect>")
            parts.append("</g>")
            y += ROW
        y += 10
    parts += _axis(x0, plot, scale_end, y)
    y += 26
    legend = [(PHASES.get(p, PHASES["other"])[0], PHASES.get(p, PHASES["other"])[1], "")
              for p in PHASES if p in used]
    if critical_drawn:
        legend.append(("#ffffff", "\u2605 critical path (outlined)",
                       ' stroke="#000" stroke-width="1.5"'))
    legend_x = x0
    for colour, text, stroke in legend:
        parts.append(f'<rect x="{legend_x}" y="{y}" width="12" height="12" fill="{colour}"'
                     f"{stroke}/>")
        parts.append(f'<text x="{legend_x + 16}" y="{y + 11}">{escape(text)}</text>')
        legend_x += 26 + 6 * len(text)
        if legend_x > width - 150:
            legend_x, y = x0, y + 18
    height = y + 22
    return (f'<svg class="timeline" xmlns="http://www.w3.org/2000/svg" width="{width}" '
            f'height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" '
            f'font-size="11">\n<rect width="{width}" height="{height}" fill="white"/>\n'
            + "\n".join(parts) + "\n</svg>\n")


def render_cpu_svg(points: Sequence[tuple[float, float]], cores: int, wall: float, *,
                   width: int = 960, height: int = 140) -> str:
    """Busy cores over time (a filled curve, one point per sample) under a dashed line at the
    cores available: the gap between them is CPU the run left idle."""
    plot_w = width - LABEL_WIDTH - 2 * MARGIN
    plot_h = height - 40
    x0, top = LABEL_WIDTH + MARGIN, MARGIN
    scale_end = max(wall, max((t for t, _ in points), default=0.0)) or 1.0
    peak = max([float(cores), *(busy for _, busy in points)]) or 1.0

    def xy(t: float, busy: float) -> str:
        return f"{_fmt(x0 + plot_w * t / scale_end)},{_fmt(top + plot_h * (1 - busy / peak))}"

    base = top + plot_h
    parts = [f'<text x="{LABEL_WIDTH}" y="{top + plot_h // 2 + 12}" text-anchor="end" '
             'fill="#4e79a7">busy cores</text>',
             f'<text x="{LABEL_WIDTH}" y="{_fmt(top + plot_h * (1 - cores / peak) + 4)}" '
             f'text-anchor="end">{cores} available</text>',
             f'<line class="available" x1="{x0}" y1="{_fmt(top + plot_h * (1 - cores / peak))}" '
             f'x2="{x0 + plot_w}" y2="{_fmt(top + plot_h * (1 - cores / peak))}" stroke="#333" '
             'stroke-dasharray="4 3"/>']
    if points:
        curve = " ".join(xy(t, busy) for t, busy in points)
        first, last = points[0][0], points[-1][0]
        area = f"{xy(first, 0)} {curve} {xy(last, 0)}"
        parts.append(f'<polygon points="{area}" fill="#4e79a7" fill-opacity="0.25"/>')
        parts.append(f'<polyline class="cpu" points="{curve}" fill="none" stroke="#4e79a7" '
                     f'stroke-width="1.5"><title>busy cores, sampled {len(points)} times'
                     "</title></polyline>")
        for t, busy in points:
            cx, cy = xy(t, busy).split(",")
            parts.append(f'<circle class="sample" cx="{cx}" cy="{cy}" r="1.5" fill="#4e79a7">'
                         f"<title>{t:.1f} s: {busy:.2f} cores busy</title></circle>")
    else:
        parts.append(f'<text x="{x0 + 4}" y="{top + plot_h // 2}" fill="#777">no samples: '
                     "the run was too short to measure</text>")
    parts += _axis(x0, plot_w, scale_end, base)
    return (f'<svg class="cpu-chart" xmlns="http://www.w3.org/2000/svg" width="{width}" '
            f'height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" '
            f'font-size="11">\n<rect width="{width}" height="{height}" fill="white"/>\n'
            + "\n".join(parts) + "\n</svg>\n")
