"""The run report (runreport/): written by every build and test run from data the run has,
the same page from the same log, `wsbuild report`, `--no-report`, `--timings`; the pieces it
is made of (critical path, compiler-cache counts per package, the status line's progress,
CPU sampling). tests/test_report_browser.py opens real reports in Chromium."""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from conftest import run_wsbuild, write_package
from wsbuild.engine.cpu_sampler import CpuSampler, tree_cpu_seconds
from wsbuild.engine.jobs import JobResult, JobStarted, Outcome, StepStarted
from wsbuild.engine.progress import Progress
from wsbuild.events import JobFinished
from wsbuild.reporter import Reporter
from wsbuild.engine.timing_files import bound_text, critical_chain
from wsbuild.runreport.model import compiler_cache_counts, load_run
from wsbuild.runreport.page import render_page, write_report


def _run_dir(ws: Path, link: str = "latest") -> Path:
    return (ws / "log" / link).resolve()


# ---------------------------------------------------------------------------- every build


def test_every_build_writes_its_report_and_the_latest_link_shows_it(built: Path) -> None:
    run = _run_dir(built)
    html = (run / "report.html").read_text()
    record = json.loads((run / "report.json").read_text())
    assert (built / "log" / "latest" / "report.html").read_text() == html
    assert record["verb"] == "build" and record["command"] == "wsbuild build"
    assert sorted(p["name"] for p in record["packages"]) == ["pa", "pb", "pc"]
    assert {p["outcome"] for p in record["packages"]} == {"finished"}
    # self-contained: nothing fetched (the SVG namespace is a name, not a request)
    assert "<script" in html and "src=" not in html and "<link" not in html
    assert "http" not in html.replace('xmlns="http://www.w3.org/2000/svg"', "")


def test_the_same_log_gives_the_same_page(built: Path) -> None:
    run = _run_dir(built)
    first = (run / "report.html").read_bytes()
    write_report(run)
    assert (run / "report.html").read_bytes() == first
    assert render_page(load_run(built / "log" / "latest_build")).encode() == first


def test_timings_prints_the_reports_path_and_no_report_writes_none(built: Path) -> None:
    timed = run_wsbuild("build", "--timings", cwd=built)
    assert timed.returncode == 0, timed.stderr
    shown = re.search(r"^  report: (.+report\.html)$", timed.stdout, re.MULTILINE)
    assert shown and Path(shown.group(1)) == _run_dir(built) / "report.html"
    plain = run_wsbuild("build", cwd=built)
    assert "report.html" not in plain.stdout  # only with --timings
    off = run_wsbuild("build", "--no-report", cwd=built)
    assert off.returncode == 0, off.stderr
    assert not (_run_dir(built) / "report.html").exists()
    assert not (_run_dir(built) / "report.json").exists()


def test_no_report_is_a_defaults_file_key(built: Path) -> None:
    (built / "wsbuild.yaml").write_text("build:\n  no-report: true\n")
    result = run_wsbuild("build", cwd=built)
    assert result.returncode == 0, result.stderr
    assert not (_run_dir(built) / "report.html").exists()


def test_a_no_op_build_writes_its_report_without_starting_a_process(built: Path) -> None:
    """The no-op path: the report comes from what the run holds and its log, with no
    subprocess (a compiler-cache query, `ninja --version`) while it is written."""
    script = """
import json, os, subprocess, sys, time
import wsbuild.runreport.write as pipeline
original = pipeline.write_run_report
spent = []
def refuse(*args, **kwargs):
    raise AssertionError("a process was started while the report was written")
def guarded(*args, **kwargs):
    saved = subprocess.Popen, os.fork, os.posix_spawn
    subprocess.Popen, os.fork, os.posix_spawn = refuse, refuse, refuse
    try:
        started = time.perf_counter()
        return original(*args, **kwargs)
    finally:
        spent.append(time.perf_counter() - started)
        subprocess.Popen, os.fork, os.posix_spawn = saved
pipeline.write_run_report = guarded
from wsbuild.cli import main
code = main(["build"])
print("REPORT-SECONDS", spent[0])
sys.exit(code)
"""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    result = subprocess.run([sys.executable, "-c", script], cwd=built, env=env,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "REPORT-SECONDS" in result.stdout
    record = json.loads((_run_dir(built) / "report.json").read_text())
    assert {p["outcome"] for p in record["packages"]} == {"up to date"}
    # a no-op's page (nothing but up-to-date names) is drawn when asked for
    assert not (_run_dir(built) / "report.html").exists()
    drawn = run_wsbuild("report", cwd=built)
    assert drawn.returncode == 0, drawn.stderr
    assert "3 up to date" in drawn.stdout
    assert (_run_dir(built) / "report.html").is_file()


def test_report_reprints_an_earlier_runs_summary_and_rewrites_its_page(built: Path) -> None:
    first = _run_dir(built)
    assert run_wsbuild("build", cwd=built).returncode == 0
    (first / "report.html").unlink()
    result = run_wsbuild("report", first.name, cwd=built)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[0].startswith(f"Run {first.name}: wsbuild build")
    assert "Summary: 3 packages finished" in result.stdout
    assert result.stdout.splitlines()[-1] == f"report: {built / 'log' / first.name / 'report.html'}"
    assert (first / "report.html").is_file()
    latest = run_wsbuild("report", cwd=built)
    assert "3 up to date" in latest.stdout
    missing = run_wsbuild("report", "build_1999", cwd=built)
    assert missing.returncode == 2 and first.name in missing.stderr


def test_restored_and_up_to_date_packages_are_drawn_and_listed_as_such(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_package(ws / "src", "pa")
    write_package(ws / "src", "pc", "cmake")
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "xdg"), WSBUILD_CACHE="")
    assert run_wsbuild("build", cwd=ws, env=env).returncode == 0
    shutil.rmtree(ws / "build" / "pa")
    shutil.rmtree(ws / "install" / "pa")
    assert run_wsbuild("build", cwd=ws, env=env).returncode == 0
    report = load_run(ws / "log" / "latest")
    rows = {row.name: row for row in report.packages}
    assert rows["pa"].restored and rows["pa"].artifact_cache == "restored (local)"
    assert rows["pc"].outcome == "up to date"
    phases = {bar.package: {phase for phase, _, _ in bar.spans} for bar in report.bars}
    assert "restored" in phases["pa"] and "up to date" in phases["pc"]
    html = (ws / "log" / "latest" / "report.html").read_text()
    assert "restored from cache" in html and "up to date" in html


def test_a_failed_build_records_the_failure_with_its_repro_and_log(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    broken = write_package(ws / "src", "broken", "cmake")
    (broken / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.14)\nproject(broken NONE)\n"
        'message(FATAL_ERROR "broken on purpose")\n')
    write_package(ws / "src", "fine", "ament_python")
    assert run_wsbuild("build", cwd=ws).returncode == 1
    report = load_run(ws / "log" / "latest")
    [failed] = report.failed
    assert failed.name == "broken" and "cmake" in failed.reproduce
    assert any("broken on purpose" in line for line in failed.tail)
    html = (ws / "log" / "latest" / "report.html").read_text()
    assert html.index('id="failures"') < html.index('class="timeline"')
    summary = run_wsbuild("report", cwd=ws)
    assert "failed: broken: 'cmake' exited with code 1" in summary.stdout


def test_a_one_package_run_is_counted_in_the_singular(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_package(ws / "src", "alone", "cmake")
    assert run_wsbuild("build", "--parallel-workers", "1", cwd=ws).returncode == 0
    html = (ws / "log" / "latest" / "report.html").read_text()
    assert "<p>1 package: 1 finished</p>" in html and "1 package at once" in html
    assert "1 packages" not in html


# ----------------------------------------------------------------------------- every test


def test_a_test_runs_report_counts_tests_and_links_failing_ones_to_junit(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    good = write_package(ws / "src", "good")
    (good / "test").mkdir()
    (good / "test" / "test_good.py").write_text("def test_one():\n    assert True\n")
    bad = write_package(ws / "src", "bad")
    (bad / "test").mkdir()
    (bad / "test" / "test_bad.py").write_text(
        "def test_fine():\n    pass\n\ndef test_math():\n    assert 1 + 1 == 3\n")
    assert run_wsbuild("build", cwd=ws).returncode == 0
    assert run_wsbuild("test", cwd=ws).returncode == 1
    run = _run_dir(ws, "latest_test")
    report = load_run(run)
    counts = {p.name: p.tests for p in report.packages}
    assert counts["good"]["tests"] == 1 and counts["good"]["failures"] == 0  # type: ignore[index]
    assert counts["bad"]["tests"] == 2 and counts["bad"]["failures"] == 1  # type: ignore[index]
    [failing] = counts["bad"]["failing"]  # type: ignore[index]
    assert failing["name"].endswith("test_math")
    assert (run / failing["junit"]).is_file()
    html = (run / "report.html").read_text()
    assert f'<a href="{failing["junit"]}">{failing["name"]}</a>' in html
    assert (run / "timings.json").is_file() and len(report.bars) == 2
    summary = run_wsbuild("report", "latest_test", cwd=ws)
    assert "Summary: 2 packages tested" in summary.stdout
    assert f"    {failing['name']} - " in summary.stdout


def test_a_test_run_times_itself_as_a_build_does_also_without_its_report(
        tmp_path: Path) -> None:
    """One run for both verbs (runreport/package_run.py): like a build, every test run writes
    timings.json/txt with each package's phases, also under --no-report, which only leaves
    out report.json and report.html."""
    ws = tmp_path / "ws"
    for name, deps in (("base", []), ("user", ["base"])):
        package = write_package(ws / "src", name, deps=deps)
        (package / "test").mkdir()
        (package / "test" / f"test_{name}.py").write_text("def test_one():\n    assert True\n")
    assert run_wsbuild("build", cwd=ws).returncode == 0
    tested = run_wsbuild("test", "--no-report", "--no-test-cache", cwd=ws)
    assert tested.returncode == 0, tested.stdout + tested.stderr
    run = _run_dir(ws, "latest_test")
    assert not (run / "report.json").exists() and not (run / "report.html").exists()
    timings = json.loads((run / "timings.json").read_text())
    rows = {p["package"]: p for p in timings["packages"]}
    assert set(rows) == {"base", "user"}
    for row in rows.values():
        assert row["outcome"] == "finished"
        assert [label for label, _, _ in row["phases"]] == ["check", "pytest"]
    # user's tests run against base's: it is ready only once base's tests finished
    assert rows["user"]["ready"] >= rows["base"]["finished"]
    assert {"wall_seconds", "cores", "job_budget"} <= set(timings)
    assert "lower bound" in (run / "timings.txt").read_text()


# ---------------------------------------------------------------------------- the pieces


def test_the_critical_path_follows_what_each_package_waited_for() -> None:
    # (package, ready: when its last dependency finished, started, finished)
    rows = [("msgs", 0.0, 0.0, 4.0), ("tool", 0.0, 0.0, 6.0), ("lib", 4.0, 4.0, 5.0),
            ("app", 6.0, 6.5, 9.0)]
    assert critical_chain(rows) == [("tool", 6.0), ("app", 2.5)]
    rows[2] = ("lib", 4.0, 4.0, 7.0)
    rows[3] = ("app", 7.0, 7.0, 9.0)
    assert critical_chain(rows) == [("msgs", 4.0), ("lib", 3.0), ("app", 2.0)]
    assert critical_chain([]) == []


def test_the_wall_time_is_told_against_its_lower_bound_with_why() -> None:
    chain = [("msgs", 4.0), ("lib", 3.0), ("app", 2.0)]
    assert bound_text(10.0, 6.0, 2, chain) == (
        "wall 10.0 s, 3.3× the lower bound of 3.0 s (CPU ÷ cores): the critical path "
        "msgs → lib → app ran one after another for 9.0 s of it")
    assert bound_text(10.0, 6.0, 2, [("big", 9.5)]).endswith(": big alone ran for 9.5 s of it")
    assert bound_text(3.3, 6.0, 2, chain) == \
        "wall 3.3 s, 1.1× the lower bound of 3.0 s (CPU ÷ cores)"
    assert "limit" not in bound_text(10.0, 6.0, 2, chain)


def test_compiler_cache_counts_go_to_the_package_holding_the_source(tmp_path: Path) -> None:
    log = tmp_path / "ccache_stats.log"
    log.write_text("# /ws/src/lib/a.cpp\ndirect_cache_hit\n# /ws/src/lib/b.cpp\ncache_miss\n"
                   "direct_cache_miss\n# /ws/build/msgs/gen/x.c\npreprocessed_cache_hit\n"
                   "# /elsewhere/y.c\ncache_miss\n")
    entries = [{"name": "lib", "path": "/ws/src/lib", "build_dir": "/ws/build/lib"},
               {"name": "msgs", "path": "/ws/src/msgs", "build_dir": "/ws/build/msgs"}]
    assert compiler_cache_counts(log, entries) == {"lib": (1, 1), "msgs": (1, 0)}


def test_compiler_cache_counts_go_to_the_package_that_compiled_wherever_the_source(
        tmp_path: Path) -> None:
    log = tmp_path / "ccache_stats.log"
    log.write_text("## package lib\n# /venv/src/gtest_vendor/src/gtest-all.cc\ncache_miss\n"
                   "# /ws/src/lib/a.cpp\ndirect_cache_hit\n"
                   "## package msgs\n# /venv/src/gtest_vendor/src/gtest-all.cc\ncache_miss\n")
    entries = [{"name": "lib", "path": "/ws/src/lib", "build_dir": "/ws/build/lib"},
               {"name": "msgs", "path": "/ws/src/msgs", "build_dir": "/ws/build/msgs"}]
    assert compiler_cache_counts(log, entries) == {"lib": (1, 1), "msgs": (0, 1)}


def test_time_left_is_the_longer_of_the_critical_path_and_the_work_per_worker() -> None:
    progress = Progress.of({"a": [], "b": ["a"], "c": [], "d": []},
                           {"a": 10.0, "b": 10.0, "c": 4.0, "d": 4.0}, workers=2)
    assert progress.seconds_left([], {}) == 20.0  # a then b
    assert progress.seconds_left(["a"], {"b": 4.0}) == 7.0  # 6 + 4 + 4 s on 2 workers
    assert progress.seconds_left(["a", "c", "d"], {"b": 4.0}) == 6.0  # the rest of b
    wide = Progress.of({n: [] for n in "abcd"}, {n: 10.0 for n in "abcd"}, workers=2)
    assert wide.seconds_left([], {}) == 20.0  # 40 s of work on 2 workers
    assert Progress.of({"a": []}, {}, workers=2).seconds_left([], {}) is None


def test_the_status_line_shows_progress_against_the_whole() -> None:
    stream = io.StringIO()
    progress = Progress.of({"a": [], "b": ["a"], "c": ["b"]}, {"a": 2.0, "b": 3.0, "c": 5.0}, 2)
    reporter = Reporter(stream, live=True, progress=progress)
    reporter(JobStarted("a"))
    reporter(StepStarted("a", "build"))
    reporter(JobFinished(JobResult("a", Outcome.FINISHED, 2.0)))
    reporter(JobStarted("b"))
    reporter(StepStarted("b", "configure"))
    status = stream.getvalue().rsplit("\r", 1)[-1]
    assert re.search(r"\[1/3 done, ~\d+ s left\] \[======>? *\] \[b:configure - 0\.\ds\]",
                     status), status
    plain = io.StringIO()
    quiet = Reporter(plain, live=False, progress=progress)
    quiet(JobStarted("a"))
    quiet(StepStarted("a", "build"))
    assert plain.getvalue() == "Starting >>> a\n"  # no status line off a terminal


def test_the_sampler_counts_the_cpu_children_use_and_stops_at_once() -> None:
    sampler = CpuSampler.started(interval=0.1)
    child = subprocess.Popen([sys.executable, "-c", "import time\nt=time.time()\n"
                              "while time.time() - t < 1.0: pass"])
    _, _, usage = os.wait4(child.pid, 0)
    time.sleep(0.15)
    before = time.monotonic()
    samples = sampler.stop()
    assert time.monotonic() - before < 0.1
    child_cpu = usage.ru_utime + usage.ru_stime
    times = [0.0, *(s.time for s in samples)]
    sampled = sum(s.busy * (times[i + 1] - times[i]) for i, s in enumerate(samples))
    assert len(samples) >= 8
    # the busy cores over time add up to the CPU the child used (however loaded the machine)
    assert abs(sampled - child_cpu) < 0.25 * child_cpu + 0.1, (sampled, child_cpu)
    assert tree_cpu_seconds(os.getpid()) is not None


def test_the_run_table_and_the_package_rows_count_the_same_compiles(tmp_path: Path) -> None:
    """A package compiling a source outside its own directories (as gtest_vendor's, under the
    underlay) counts it in its row, so the run's count is the rows' sum; one miss is "1 miss"."""
    from test_build_helpers import write_cmake

    ws = tmp_path / "ws"
    shared = tmp_path / "shared"
    shared.mkdir()
    (shared / "common.c").write_text("int common(void) { return 1; }\n")
    write_cmake(ws / "src", "uses_shared", "cmake_minimum_required(VERSION 3.14)\n"
                "project(uses_shared C)\n"
                f"add_library(uses_shared SHARED own.c {shared / 'common.c'})\n"
                "install(TARGETS uses_shared DESTINATION lib)\n",
                files={"own.c": "int own(void) { return 2; }\n"})
    write_cmake(ws / "src", "single", "cmake_minimum_required(VERSION 3.14)\nproject(single C)\n"
                "add_library(single SHARED one.c)\ninstall(TARGETS single DESTINATION lib)\n",
                files={"one.c": "int one(void) { return 3; }\n"})
    env = dict(os.environ, CCACHE_DIR=str(tmp_path / "ccache"), WSBUILD_CACHE="")
    done = run_wsbuild("build", "--no-cache", "--compiler-cache", "ccache", cwd=ws, env=env)
    assert done.returncode == 0, done.stderr
    assert "compiler cache (ccache): 0 hits, 3 misses" in done.stdout
    report = load_run(ws / "log" / "latest")
    rows = {row.name: row.compiler_cache for row in report.packages}
    assert rows == {"uses_shared": "0 hits, 2 misses", "single": "0 hits, 1 miss"}
    assert report.compiled == (0, 3)
    html = (ws / "log" / "latest" / "report.html").read_text()
    assert "ccache: 0 hits, 3 misses, 0 not cacheable" in html
    shutil.rmtree(ws / "build" / "single")
    shutil.rmtree(ws / "install" / "single")
    again = run_wsbuild("build", "--no-cache", "--compiler-cache", "ccache", cwd=ws, env=env)
    assert "compiler cache (ccache): 1 hit, 0 misses" in again.stdout


def test_timings_report_and_page_tell_the_wall_against_its_lower_bound(tmp_path: Path) -> None:
    """A chain of packages (each needs the one before): timings.txt, `wsbuild report` and the
    page say what the bound is and, when the run was well above it, name the chain."""
    ws = tmp_path / "ws"
    write_package(ws / "src", "chain_a", "cmake")
    write_package(ws / "src", "chain_b", "cmake", ["chain_a"])
    write_package(ws / "src", "chain_c", "cmake", ["chain_b"])
    done = run_wsbuild("build", "--timings", "--no-cache", cwd=ws)
    assert done.returncode == 0, done.stderr
    timings = json.loads((ws / "log" / "latest" / "timings.json").read_text())
    ratio = timings["wall_seconds"] / timings["limit_seconds"]
    words = "the critical path chain_a → chain_b → chain_c ran one after another for"
    last = (ws / "log" / "latest" / "timings.txt").read_text().splitlines()[-1]
    printed = run_wsbuild("report", cwd=ws).stdout
    page = (ws / "log" / "latest" / "report.html").read_text()
    for text in (last, done.stdout, printed, page):
        assert "× the lower bound of" in text and "(CPU ÷ cores)" in text, text
        assert "the limit" not in text
        assert (words in text) == (ratio >= 1.2), (ratio, text)
