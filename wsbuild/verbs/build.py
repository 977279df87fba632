"""`wsbuild build`: argument handling around pipeline.run_build."""

from __future__ import annotations

import argparse

from wsbuild.build.pipeline import Plan, run_build
from wsbuild.options import build_request
from wsbuild.report import Reporter
from wsbuild.verbs.load import load


def run_build_verb(args: argparse.Namespace) -> int:
    """Build the selected packages."""
    request = build_request(args)
    loaded = load(args)
    plan = Plan(loaded.workspace, loaded.packages, loaded.graph, loaded.selected)
    reporter = Reporter()
    reporter.start_ticker()
    try:
        run_build(plan, request, reporter)
    finally:
        reporter.stop()
    return 0
