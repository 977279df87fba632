"""`report.html`: one self-contained page (inline CSS and SVG, a few lines of JavaScript to sort
the table; nothing fetched) drawn from a RunReport. Same run data, same bytes."""

from __future__ import annotations

from collections.abc import Sequence
from html import escape
from pathlib import Path

from wsbuild.engine.memory_budget import format_size
from wsbuild.engine.timeline import Timeline, render_cpu_svg, render_svg
from wsbuild.engine.timing_files import bound_text
from wsbuild.runreport.model import PackageRow, RunReport, compiler_cache_text, load_run
from wsbuild.runreport.report_json import REPORT_HTML
from wsbuild.redaction import redact
from wsbuild.words import plural

_CSS = """
body{font-family:sans-serif;font-size:14px;margin:16px 24px;color:#222;max-width:1100px}
h1{font-size:20px;margin:0 0 4px} h2{font-size:16px;margin:22px 0 6px}
.ok{color:#2b7a2b} .bad{color:#b3261e}
table{border-collapse:collapse} td,th{padding:3px 8px;text-align:left;vertical-align:top}
table.facts td:first-child{color:#555;white-space:nowrap}
table.packages th{cursor:pointer;background:#eee;position:sticky;top:0;user-select:none}
table.packages td{border-top:1px solid #ddd}
td.num,th.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
tr.failed td{background:#fdecea} tr.critical td:first-child{font-weight:bold}
section.failure{border:2px solid #b3261e;border-radius:4px;padding:8px 12px;margin:10px 0;
 background:#fff8f7}
pre{background:#f4f4f4;padding:6px 8px;overflow-x:auto;font-size:12px;margin:4px 0}
code{font-size:12px}
"""

_JS = """
document.querySelectorAll('table.packages th').forEach(function (th, column) {
  th.addEventListener('click', function () {
    var body = th.closest('table').tBodies[0];
    var rows = Array.prototype.slice.call(body.rows);
    var down = th.getAttribute('data-order') !== 'desc';
    th.parentNode.querySelectorAll('th').forEach(function (h) { h.removeAttribute('data-order'); });
    th.setAttribute('data-order', down ? 'desc' : 'asc');
    rows.sort(function (a, b) {
      var x = a.cells[column].getAttribute('data-sort');
      var y = b.cells[column].getAttribute('data-sort');
      var nx = parseFloat(x), ny = parseFloat(y);
      var c = (isNaN(nx) || isNaN(ny)) ? x.localeCompare(y) : nx - ny;
      return down ? -c : c;
    });
    rows.forEach(function (r) { body.appendChild(r); });
  });
});
"""


def _seconds(value: float) -> str:
    return f"{value:.2f} s"


def _link(href: str | None, text: str) -> str:
    if not href:
        return escape(text)
    return f'<a href="{escape(href)}">{escape(text)}</a>'


def _headline(report: RunReport) -> str:
    counts: dict[str, int] = {}
    for row in report.packages:
        counts[row.outcome] = counts.get(row.outcome, 0) + 1
    verdict = "failed" if report.failed else "succeeded"
    parts = ", ".join(f"{n} {outcome}" for outcome, n in sorted(counts.items()))
    css = "bad" if report.failed else "ok"
    return (f'<h1>wsbuild {escape(report.verb)} <span class="{css}">{verdict}</span> '
            f"in {_seconds(report.wall)}</h1>\n<p>{plural(len(report.packages), 'package')}: "
            f"{escape(parts)}</p>")


def _workers(workers: object) -> str:
    """`1 package`, `4 packages`: how many packages the run built or tested at once."""
    return plural(workers, "package") if isinstance(workers, int) else f"{workers} packages"


def _failures(report: RunReport) -> str:
    if not report.failed:
        return ""
    parts = ['<h2 id="failures" class="bad">Failed</h2>']
    for row in report.failed:
        parts.append(f'<section class="failure" data-package="{escape(row.name)}">')
        parts.append(f"<h3>{escape(row.name)} {escape(row.outcome)} after "
                     f"{_seconds(row.seconds)}</h3>")
        message = _without_tail(row)
        if message:
            parts.append(f'<pre class="message">{escape(message)}</pre>')
        if row.reproduce:
            parts.append("<p>Reproduce by hand:</p>")
            parts.append(f'<pre class="reproduce">{escape(row.reproduce)}</pre>')
        if row.tail:
            where = f"{row.log_dir}/stdout_stderr.log" if row.log_dir else "the log"
            parts.append(f"<p>Last lines of {_link(where, where)}:</p>")
            parts.append(f'<pre class="tail">{escape(chr(10).join(row.tail))}</pre>')
        parts.append(_failing_tests(row))
        parts.append("</section>")
    return "\n".join(parts)


def _without_tail(row: PackageRow) -> str:
    """A failure's message without the log lines it quotes (the tail is shown on its own)."""
    if not row.tail:
        return row.message
    return "\n".join(line for line in row.message.splitlines() if not line.startswith("    "))


def _failing_tests(row: PackageRow) -> str:
    if not row.tests or not row.tests.get("failing"):
        return ""
    items = []
    for case in row.tests["failing"]:  # type: ignore[union-attr]
        items.append(f"<li>{_link(case.get('junit'), case['name'])}"
                     f" &ndash; {escape(str(case.get('headline', '')))}</li>")
    return '<ul class="failing-tests">' + "".join(items) + "</ul>"


def _facts(report: RunReport) -> str:
    record, timings = report.record, report.timings
    cpu: dict[str, float] = timings.get("cpu_seconds", {})  # type: ignore[assignment]
    cores = int(record.get("cores", timings.get("cores", 1)) or 1)  # type: ignore[call-overload]
    total = float(cpu.get("total", 0.0))
    limit = total / cores
    rows = [("command", f"<code>{escape(str(record.get('command', '')))}</code>"),
            ("wsbuild", escape(str(record.get("version", "")))),
            ("started", escape(str(record.get("started", "")))),
            ("workspace", f"<code>{escape(str(record.get('workspace', '')))}</code>"),
            ("jobs", f"{cores} CPUs{' (one jobserver)' if report.verb == 'build' else ''}, "
                     f"{escape(_workers(record.get('workers')))} at once")]
    if record.get("verb") == "build":
        compiler = record.get("compiler_cache")
        if isinstance(compiler, dict):
            # one count: the package rows' sum where they have one (ccache)
            hits, misses = report.compiled or (int(compiler["hits"]), int(compiler["misses"]))
            compiler_text = (f"{compiler['tool']}: {compiler_cache_text(hits, misses)}, "
                             f"{compiler['uncacheable']} not cacheable")
        else:
            compiler_text = str(record.get('compiler_cache_choice', ''))
        rows += [("generator", escape(str(record.get("generator", "")))),
                 ("compiler cache", escape(str(compiler_text))),
                 ("build cache", escape(str(record.get("artifact_cache", ""))))]
    rows += _memory_rows(report)
    rows += [("wall", _seconds(report.wall)),
             ("CPU", f"{_seconds(total)} (wsbuild itself "
                     f"{_seconds(float(cpu.get('wsbuild', 0.0)))})"),
             ("lower bound", f"{_seconds(limit)} = CPU &divide; {cores} cores: no run can be "
                             "shorter (every core busy throughout)"),
             ("against the bound", escape(bound_text(report.wall, total, cores, report.chain)))]
    body = "".join(f"<tr><td>{k}</td><td>{v}</td></tr>" for k, v in rows)
    return f'<h2>Run</h2>\n<table class="facts">{body}</table>'


def _memory_rows(report: RunReport) -> list[tuple[str, str]]:
    """The memory budget and where it came from, the build's peak, the waits."""
    memory = report.memory
    if memory is None:
        return []
    budget = memory.get("budget")
    if not isinstance(budget, dict):
        return []
    waited = float(memory.get("waited_seconds", 0.0) or 0.0)  # type: ignore[arg-type]
    held = float(memory.get("held_back_token_seconds", 0.0) or 0.0)  # type: ignore[arg-type]
    alone = [str(n) for n in memory.get("alone", []) or []]  # type: ignore[union-attr]
    rows = [("memory budget", f"{_size(budget.get('bytes'))} "
                              f"({escape(str(budget.get('source', '')))})"),
            ("memory peak", f"{_size(memory.get('peak'))}: wsbuild and every process it "
                            "started, at the largest (sampled every 0.1 s)"),
            ("waited for memory", f"packages {waited:.1f} s before starting or before a "
                                  f"step, {held:.1f} token-seconds of jobs held back")]
    if alone:
        rows.append(("ran alone", escape(", ".join(alone)) + ": more than the budget leaves "
                     "beside others"))
    return rows


def _size(value: object) -> str:
    return format_size(value) if isinstance(value, int) else "?"


def _timeline(report: RunReport) -> str:
    svg = render_svg([Timeline("", report.bars, report.wall)])
    path = " &rarr; ".join(escape(n) for n in report.critical_path) or "none"
    return (f"<h2>Timeline</h2>\n<p>Critical path (\u2605, outlined): "
            f'<span class="critical-path">{path}</span>. Hover a bar for its exact times.</p>\n'
            + svg)


def _cpu(report: RunReport) -> str:
    samples: list[list[float]] = report.record.get("cpu", [])  # type: ignore[assignment]
    points = [(float(t), float(busy)) for t, busy in samples]
    cores = int(report.record.get("cores", 1) or 1)  # type: ignore[call-overload]
    return "<h2>CPU use</h2>\n" + render_cpu_svg(points, cores, report.wall)


def _cell(text: str, sort: str | float, *, num: bool = False) -> str:
    css = ' class="num"' if num else ""
    return f'<td{css} data-sort="{escape(str(sort))}">{text}</td>'


def _table(report: RunReport) -> str:
    testing = report.verb == "test"
    phases = [p for p in ("configure", "build", "install", "test", "other")
              if any(p in row.phases for row in report.packages)]
    memory = not testing and report.memory is not None
    heads = ["package", "outcome", "duration", "waiting", *phases]
    heads += ["peak memory", "waited for memory"] if memory else []
    heads += ["passed", "failed", "skipped", "note"] if testing else \
        ["reason to build", "compiler cache", "build cache"]
    heads.append("log")
    numeric = {"duration", "waiting", "passed", "failed", "skipped", "peak memory",
               "waited for memory", *phases}
    head = "".join(f'<th class="num">{h}</th>' if h in numeric else f"<th>{h}</th>"
                   for h in heads)
    rows = []
    for row in sorted(report.packages, key=lambda r: (-r.seconds, r.name)):
        css = " ".join(c for c in ("failed" if row.failed else "",
                                   "critical" if row.critical else "") if c)
        name = ("\u2605 " if row.critical else "") + row.name
        cells = [_cell(escape(name), row.name), _cell(escape(row.outcome), row.outcome),
                 _cell(_seconds(row.seconds), row.seconds, num=True),
                 _cell(_seconds(row.waiting), row.waiting, num=True)]
        cells += [_cell(_seconds(row.phases[p]) if p in row.phases else "", row.phases.get(p, 0),
                        num=True) for p in phases]
        if memory:
            cells += [_cell(_size(row.memory_peak) if row.memory_peak is not None else "",
                            row.memory_peak or 0, num=True),
                      _cell(_seconds(row.memory_wait) if row.memory_wait else "",
                            row.memory_wait, num=True)]
        if testing:
            tests = {k: int(v) for k, v in (row.tests or {}).items()  # type: ignore[call-overload]
                     if k in ("tests", "failures", "errors", "skipped")}
            failed = tests.get("failures", 0) + tests.get("errors", 0)
            skipped = tests.get("skipped", 0)
            passed = tests.get("tests", 0) - failed - skipped
            cells += [_cell(str(passed), passed, num=True), _cell(str(failed), failed, num=True),
                      _cell(str(skipped), skipped, num=True),
                      # a cached result, or why a package's tests did not run
                      _cell(escape(row.reason), row.reason)]
        else:
            cells += [_cell(escape(row.reason), row.reason),
                      _cell(escape(row.compiler_cache), row.compiler_cache),
                      _cell(escape(row.artifact_cache), row.artifact_cache)]
        log = _link(row.log_dir + "/", row.log_dir + "/") if row.log_dir else ""
        cells.append(_cell(log, row.log_dir or ""))
        attr = f' class="{css}"' if css else ""
        rows.append(f'<tr{attr} data-package="{escape(row.name)}">{"".join(cells)}</tr>')
    return (f"<h2>Packages</h2>\n<p>Click a column to sort.</p>\n"
            f'<table class="packages"><thead><tr>{head}</tr></thead>\n<tbody>\n'
            + "\n".join(rows) + "\n</tbody></table>")


def render_page(report: RunReport) -> str:
    title = f"wsbuild {report.verb}: {report.run_dir.name}"
    sections: Sequence[str] = (
        _headline(report), _failures(report), _facts(report), _timeline(report), _cpu(report),
        _table(report))
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{escape(title)}</title>\n<style>{_CSS}</style></head>\n<body>\n"
            + "\n".join(s for s in sections if s)
            + f"\n<script>{_JS}</script>\n</body></html>\n")


def write_report(run_dir: Path) -> Path:
    """(Re)write `run_dir/report.html` from the run's log directory; its path."""
    page = render_page(load_run(run_dir))
    path = run_dir / REPORT_HTML
    # written in place: each run has its own directory, and nothing reads it while it is
    # written (a rename would cost the no-op path a metadata write on a busy disk)
    path.write_text(redact(page), encoding="utf-8")
    return path
