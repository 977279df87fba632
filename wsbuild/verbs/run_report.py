"""`wsbuild report [RUN]`: an earlier run's summary again, and its report page (rewritten from
the run's log directory)."""

from __future__ import annotations

import argparse

from wsbuild.errors import WorkspaceError

REPORT_DOC = """Show the summary of an earlier build or test run and the path of its report.

RUN is a directory under log/ (build_2026-01-31_12-00-00, latest_build, latest_test; default:
latest). The report page (log/RUN/report.html: timeline, critical path, CPU use, packages) is
written again from the run's log directory, so it also comes back when deleted.

examples:
  wsbuild report
  wsbuild report latest_test

exit codes: 0 shown, 2 no such run or the run wrote no report (--no-report)
"""


def add_report_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run", nargs="?", default="latest", metavar="RUN",
                        help="a run directory under log/ (default: latest)")
    parser.add_argument("-C", "--workspace", metavar="DIR", dest="workspace_dir",
                        help="the workspace root (default: found from the current directory)")
    parser.add_argument("--log-base", default="log", metavar="DIR",
                        help="log directory, relative to the workspace (default: log)")


def run_report(args: argparse.Namespace) -> int:
    """Print an earlier run's summary and the path of its (rewritten) report."""
    from wsbuild.runreport.model import (
        NoReport, load_run, summary_lines)  # lazy: off Tab completion
    from wsbuild.runreport.page import render_page  # lazy: off Tab completion and `--help`
    from wsbuild.runreport.report_json import REPORT_HTML  # lazy: off Tab completion and `--help`
    from wsbuild.verbs.load import workspace_root  # lazy: off Tab completion and `--help`

    log_base = workspace_root(args.workspace_dir) / args.log_base
    run_dir = log_base / args.run
    if not run_dir.is_dir():
        runs = sorted(p.name for p in log_base.glob("*_*") if p.is_dir() and not p.is_symlink())
        raise WorkspaceError(f"no run '{args.run}' in {log_base}",
                             hint=("runs: " + ", ".join(runs[-5:])) if runs
                             else "build or test first")
    try:
        report = load_run(run_dir)
    except NoReport:
        raise WorkspaceError(f"run {run_dir.resolve().name} wrote no report",
                             path=run_dir, hint="it ran with --no-report") from None
    page = run_dir / REPORT_HTML
    text = render_page(report)
    if not page.is_file() or page.read_text(encoding="utf-8") != text:
        page.write_text(text, encoding="utf-8")
    for line in summary_lines(report):
        print(line)
    print(f"report: {page}")
    return 0
