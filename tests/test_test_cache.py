"""Cached test results on real workspaces (testing/cached_result.py): a package's last passing
result is reused while nothing its tests read changed, and runs again after anything they
read did (observed, as a build's steps are). Each package's test counts its runs in
<ws>/ran/<pkg> (outside every package, so counting changes no package's files): what ran is
measured, not guessed."""

from __future__ import annotations

import json
import os
import re
import stat
import subprocess
from pathlib import Path

import pytest

from conftest import run_wsbuild, write_package

#: a test that counts its runs, and fails on the runs its plan says (`fail` / `pass` per run)
COUNTING_TEST = '''from pathlib import Path

RAN = Path(__file__).resolve().parents[3] / "ran"


def test_counts_its_runs():
    RAN.mkdir(exist_ok=True)
    counter = RAN / "{name}"
    runs = int(counter.read_text()) if counter.exists() else 0
    counter.write_text(str(runs + 1))
    plan = "{plan}".split()
    assert plan[min(runs, len(plan) - 1)] == "pass", "planned to fail on run " + str(runs + 1)


def test_imports_what_it_tests():
    import {name}.main  # noqa: F401
'''

CM_CMAKELISTS = """cmake_minimum_required(VERSION 3.14)
project(cm NONE)
enable_testing()
add_test(NAME counts COMMAND sh -c "mkdir -p ${{RAN}} && echo x >> ${{RAN}}/cm")
install(FILES package.xml DESTINATION share/cm)
"""

#: root ← mid ← leaf (leaf only exec-depends on mid: its tests still see root), other, cm
SPEC = {"root": [], "mid": ["root"], "other": []}


def _env(**extra: str) -> dict[str, str]:
    env = dict(os.environ)
    env.update(ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID="71")
    env.update(extra)
    return env


def _test(ws: Path, *args: str, **env: str) -> subprocess.CompletedProcess[str]:
    return run_wsbuild("test", *args, cwd=ws, env=_env(**env))


def _build(ws: Path) -> None:
    done = run_wsbuild("build", cwd=ws, env=_env())
    assert done.returncode == 0, done.stdout + done.stderr


def _counting(package: Path, name: str, plan: str = "pass") -> None:
    (package / "test").mkdir(exist_ok=True)
    (package / "test" / "test_counts.py").write_text(COUNTING_TEST.format(name=name, plan=plan))


def _workspace(root: Path, plans: dict[str, str] | None = None) -> Path:
    ws = root / "ws"
    src = ws / "src"
    for name, deps in SPEC.items():
        _counting(write_package(src, name, deps=deps), name, (plans or {}).get(name, "pass"))
    _counting(write_package(src, "leaf", kinds={"exec_depend": ["mid"]}), "leaf")
    cm = write_package(src, "cm", "cmake")
    (cm / "CMakeLists.txt").write_text(CM_CMAKELISTS.format().replace(
        "${RAN}", str(ws / "ran")))
    _build(ws)
    return ws


def runs(ws: Path) -> dict[str, int]:
    """How often each package's tests have run so far."""
    ran = ws / "ran"
    counts = {}
    for counter in sorted(ran.iterdir()) if ran.is_dir() else []:
        text = counter.read_text()
        counts[counter.name] = len(text.split()) if counter.name == "cm" else int(text)
    return counts


def ran_since(ws: Path, before: dict[str, int]) -> list[str]:
    return sorted(name for name, count in runs(ws).items() if count != before.get(name, 0))


def cached(result: subprocess.CompletedProcess[str]) -> dict[str, str]:
    """package -> its `cached: ...` line."""
    return dict(re.findall(r"^\[(\w+)\] cached: (.*)$", result.stdout, re.MULTILINE))


def summary(result: subprocess.CompletedProcess[str]) -> str:
    line = next(line for line in result.stdout.splitlines() if line.startswith("Summary:"))
    return re.sub(r" \[[\d.]+s\]$", "", line)


@pytest.fixture
def ws(tmp_path: Path) -> Path:
    return _workspace(tmp_path)


def test_a_second_test_reruns_nothing_and_shows_the_results_as_they_were(ws: Path) -> None:
    first = _test(ws, ROS_SECRET_PROBE="never-on-disk-3141")
    assert first.returncode == 0, first.stdout + first.stderr
    assert runs(ws) == {"cm": 1, "leaf": 1, "mid": 1, "other": 1, "root": 1}
    assert cached(first) == {}
    before = runs(ws)
    results_before = run_wsbuild("test-result", "--all", cwd=ws).stdout

    again = _test(ws, ROS_SECRET_PROBE="never-on-disk-3141")
    assert again.returncode == 0, again.stdout + again.stderr
    assert ran_since(ws, before) == []
    assert "Starting >>>" not in again.stdout
    shown = cached(again)
    assert sorted(shown) == ["cm", "leaf", "mid", "other", "root"]
    assert summary(again) == summary(first) == \
        "Summary: 5 packages tested, 9 tests, 0 errors, 0 failures, 0 skipped"
    assert "    of which cached (nothing their tests observe changed; --no-test-cache runs " \
           "them): cm leaf mid other root" in again.stdout.splitlines()
    # the original counts, the original log and the JUnit files, which are still there
    log = re.fullmatch(r"2 tests, 0 errors, 0 failures, 0 skipped "
                       r"\(log: (\S+), results: (\S+)\)", shown["root"])
    assert log, shown["root"]
    assert "2 passed" in (ws / log[1]).read_text()
    first_log = sorted((ws / "log").glob("test_*"))[0]
    assert (ws / log[1]).parent == first_log / "root"
    assert (ws / log[2] / "pytest.xml").is_file()
    assert shown["cm"].startswith("1 test, 0 errors, 0 failures, 0 skipped (log: ")
    # test-result reports them as what they were
    assert run_wsbuild("test-result", "--all", cwd=ws).stdout == results_before
    # and the run's report page says which results were cached
    record = json.loads((ws / "log" / "latest_test" / "report.json").read_text())
    assert {p["name"] for p in record["packages"] if p["tests"]["cached"]} == set(shown)
    page = (ws / "log" / "latest_test" / "report.html").read_text()
    assert page.count("cached: the result of an earlier run") >= len(shown)
    # the record: private, digests only
    record = ws / "build" / "root" / ".wsbuild" / "test_result.json"
    assert stat.S_IMODE(record.stat().st_mode) == 0o600
    assert stat.S_IMODE(record.parent.stat().st_mode) == 0o700
    text = record.read_text()
    assert "never-on-disk-3141" not in text and "LOCALHOST" not in text
    held = json.loads(text)["environment"]
    # a variable no test read is no input; one pytest read is, by its value's digest
    assert "ROS_SECRET_PROBE" not in held and "PYTEST_ADDOPTS" in held


def test_after_a_leaf_package_is_edited_only_its_tests_run(ws: Path) -> None:
    assert _test(ws).returncode == 0
    before = runs(ws)
    main = ws / "src" / "leaf" / "leaf" / "main.py"
    main.write_text(main.read_text() + "# edited\n")
    _build(ws)
    again = _test(ws)
    assert again.returncode == 0, again.stdout + again.stderr
    assert ran_since(ws, before) == ["leaf"]
    assert sorted(cached(again)) == ["cm", "mid", "other", "root"]


def test_after_a_root_package_is_edited_everything_that_sees_it_runs(ws: Path) -> None:
    assert _test(ws).returncode == 0
    before = runs(ws)
    main = ws / "src" / "root" / "root" / "main.py"
    main.write_text(main.read_text() + "# edited\n")
    _build(ws)
    again = _test(ws)
    assert again.returncode == 0, again.stdout + again.stderr
    # leaf only exec-depends on mid, whose run dependency root is on leaf's test environment
    assert ran_since(ws, before) == ["leaf", "mid", "root"]
    assert sorted(cached(again)) == ["cm", "other"]
    log = sorted((ws / "log").glob("test_*"))[-1] / "mid" / "command.log"
    assert re.search(r"^test result not reused: (the package was rebuilt|rebuilt on its test "
                     r"environment: root)$", log.read_text(), re.MULTILINE)


def test_a_test_edited_without_a_rebuild_runs_again(ws: Path) -> None:
    assert _test(ws).returncode == 0
    before = runs(ws)
    test_file = ws / "src" / "other" / "test" / "test_counts.py"
    test_file.write_text(test_file.read_text() + "\n\ndef test_added():\n    pass\n")
    again = _test(ws)
    assert again.returncode == 0, again.stdout + again.stderr
    assert ran_since(ws, before) == ["other"]
    assert "Summary: 5 packages tested, 10 tests," in again.stdout


def test_a_flaky_test_that_failed_once_runs_again(tmp_path: Path) -> None:
    ws = _workspace(tmp_path, {"other": "fail pass"})
    first = _test(ws)
    assert first.returncode == 1
    before = runs(ws)
    second = _test(ws)
    assert second.returncode == 0, second.stdout + second.stderr
    assert ran_since(ws, before) == ["other"]
    assert "other" not in cached(second)
    # now it passed: the next run reuses that
    before = runs(ws)
    assert _test(ws).returncode == 0
    assert ran_since(ws, before) == []


def test_a_pass_that_needed_a_retry_is_not_kept(tmp_path: Path) -> None:
    ws = _workspace(tmp_path, {"other": "fail pass"})
    first = _test(ws, "--retest-until-pass", "1")
    assert first.returncode == 0, first.stdout + first.stderr
    assert "flaky: other passed on attempt 2 of 2" in first.stdout
    before = runs(ws)
    again = _test(ws, "--retest-until-pass", "1")
    assert ran_since(ws, before) == ["other"]
    assert sorted(cached(again)) == ["cm", "leaf", "mid", "root"]


def test_no_test_cache_and_its_defaults_key_run_everything(ws: Path) -> None:
    assert _test(ws).returncode == 0
    before = runs(ws)
    forced = _test(ws, "--no-test-cache")
    assert forced.returncode == 0
    assert ran_since(ws, before) == ["cm", "leaf", "mid", "other", "root"]
    assert cached(forced) == {}
    (ws / "wsbuild.yaml").write_text("test:\n  no-test-cache: true\n")
    before = runs(ws)
    assert _test(ws).returncode == 0
    assert ran_since(ws, before) == ["cm", "leaf", "mid", "other", "root"]
    (ws / "wsbuild.yaml").unlink()
    # what those runs passed is kept: the next plain run reuses it
    before = runs(ws)
    assert _test(ws).returncode == 0
    assert ran_since(ws, before) == []


def test_a_variable_a_test_reads_reruns_it_and_one_no_test_reads_is_ignored(ws: Path) -> None:
    """A test that reads TURTLEBOT3_MODEL runs again when it changes, the others do not; a
    variable pytest itself reads reruns every pytest package; the terminal's, an editor's
    and a CI run's own do not (observed: testing/cached_result.py)."""
    test = ws / "src" / "root" / "test" / "test_model.py"
    test.write_text("import os\n\n\ndef test_model():\n"
                    "    assert os.environ.get('TURTLEBOT3_MODEL', 'burger') in "
                    "('burger', 'waffle')\n")
    _build(ws)
    assert _test(ws).returncode == 0
    before = runs(ws)
    ignored = _test(ws, TERM="dumb", COLUMNS="77", GITHUB_RUN_ID="4242", EDITOR="vim",
                    ROS_DOMAIN_ID="72", GNOME_TERMINAL_SCREEN="/org/gnome/x")
    assert ignored.returncode == 0, ignored.stdout + ignored.stderr
    assert ran_since(ws, before) == []
    for changed, expected in (({"TURTLEBOT3_MODEL": "waffle"}, ["root"]),
                              ({"PYTEST_ADDOPTS": "-q"}, ["leaf", "mid", "other", "root"])):
        before = runs(ws)
        again = _test(ws, **changed)
        assert again.returncode == 0, again.stdout + again.stderr
        assert ran_since(ws, before) == expected, changed
    log = sorted((ws / "log").glob("test_*"))[-1] / "root" / "command.log"
    # the run before had TURTLEBOT3_MODEL, this one PYTEST_ADDOPTS instead
    assert "test result not reused: environment variables changed: PYTEST_ADDOPTS " \
           "TURTLEBOT3_MODEL" in log.read_text()


def test_other_test_options_rerun(ws: Path) -> None:
    assert _test(ws).returncode == 0
    before = runs(ws)
    assert _test(ws, "--pytest-args", "-v", "--").returncode == 0
    assert ran_since(ws, before) == ["leaf", "mid", "other", "root"]
    before = runs(ws)
    # the pytest arguments as before, other CTest ones: only CTest's package runs
    again = _test(ws, "--pytest-args", "-v", "--", "--ctest-args", "--timeout", "60", "--")
    assert again.returncode == 0, again.stdout + again.stderr
    assert ran_since(ws, before) == ["cm"]


def test_deleted_results_run_again(ws: Path) -> None:
    assert _test(ws).returncode == 0
    (ws / "build" / "mid" / "test_results" / "mid" / "pytest.xml").unlink()
    before = runs(ws)
    assert _test(ws).returncode == 0
    assert ran_since(ws, before) == ["mid"]


def test_cache_selection_on_test_means_the_cached_result_applies(ws: Path) -> None:
    assert _test(ws).returncode == 0
    valid = run_wsbuild("list", "-n", "--packages-select-cache-invalid",
                        "--packages-select-cache-key", "test", cwd=ws, env=_env())
    assert valid.returncode == 0 and valid.stdout.split() == []
    before = runs(ws)
    again = _test(ws, "--packages-select-cache-invalid")
    assert again.returncode == 0 and ran_since(ws, before) == []
    # a variable pytest reads changed: no cached result of a pytest package applies, those are
    # selected and run
    changed = _test(ws, "--packages-skip-cache-valid", PYTEST_ADDOPTS="-q")
    assert changed.returncode == 0, changed.stdout + changed.stderr
    assert ran_since(ws, before) == ["leaf", "mid", "other", "root"]


# ------------------------------------------------------------------ the key's pure logic


def test_a_changed_key_says_what_changed_first_in_the_dirty_checks_words() -> None:
    from wsbuild.record.dirty import Dirty, Reason
    from wsbuild.record.tested import TestKey

    key = TestKey(build="b", closure={"dep": "1"}, sources="s", options="o", tools="t")
    assert key.changed_since(key) is None
    assert TestKey("b", {"dep": "2"}, "s", "o", "t").changed_since(key) == \
        Reason(Dirty.DEPENDENCY, "rebuilt on its test environment: dep", details=("dep",))
    assert TestKey("b", {"dep": "1"}, "s", "o2", "t").changed_since(key) == \
        Reason(Dirty.OPTIONS, "other test options")
    assert TestKey("c", {"dep": "1"}, "s2", "o", "t").changed_since(key) == \
        Reason(Dirty.REBUILT, "the package was rebuilt")
    assert TestKey("b", {"dep": "1"}, "s2", "o", "t").changed_since(key) == \
        Reason(Dirty.SOURCE, "a file of the package changed")
    assert TestKey("b", {"dep": "1"}, "s", "o", "t", underlays="u").changed_since(key) == \
        Reason(Dirty.EXTERNAL, "an underlay workspace's package it runs against changed")
    assert TestKey("b", {"dep": "1"}, "s", "o", "t2").changed_since(key).kind is Dirty.EXTERNAL


def test_a_rerun_has_a_typed_reason_for_each_way_a_result_stops_holding() -> None:
    from wsbuild.record.dirty import Dirty
    from wsbuild.record.tested import TestKey, TestRun, rerun_reason

    from wsbuild.record.environment import variable_digests

    key = TestKey(build="b", closure={}, sources="s", options="o", tools="t")
    # its run read PYTEST_ADDOPTS, which was not set
    run = TestRun(key, environment=variable_digests({}, ["PYTEST_ADDOPTS"]))
    assert rerun_reason(key, run, environ={}) is None
    kinds = {
        "forced": rerun_reason(key, run, forced=True),
        "no key": rerun_reason(None, run),
        "no result": rerun_reason(key, None),
        "key": rerun_reason(TestKey("b", {}, "s", "o2", "t"), run),
        "unobserved": rerun_reason(key, TestRun(key, unobserved=("a static binary",))),
        "results": rerun_reason(key, TestRun(key, results_kept=False)),
        "variable": rerun_reason(key, run, environ={"PYTEST_ADDOPTS": "-q"}),
    }
    assert {name: reason.kind if reason else None for name, reason in kinds.items()} == {
        "forced": Dirty.FORCED, "no key": Dirty.NEW, "no result": Dirty.NEW,
        "key": Dirty.OPTIONS, "unobserved": Dirty.UNOBSERVED, "results": Dirty.RESULTS,
        "variable": Dirty.ENVIRONMENT}
    assert kinds["variable"] is not None and kinds["variable"].details == ("PYTEST_ADDOPTS",)


def test_with_a_symlink_install_an_edited_dependency_reruns_its_users_unbuilt(
        tmp_path: Path) -> None:
    """A symlink install links to the sources: an edit reaches the users' tests at once."""
    ws = _workspace(tmp_path)
    built = run_wsbuild("build", "--symlink-install", cwd=ws, env=_env())
    assert built.returncode == 0, built.stdout + built.stderr
    assert _test(ws).returncode == 0
    before = runs(ws)
    main = ws / "src" / "root" / "root" / "main.py"
    main.write_text(main.read_text() + "# edited, not rebuilt\n")
    again = _test(ws)
    assert again.returncode == 0, again.stdout + again.stderr
    assert ran_since(ws, before) == ["leaf", "mid", "root"]
    assert sorted(cached(again)) == ["cm", "other"]


def test_tests_skipped_for_a_missing_linter_are_cached_and_still_named(ws: Path) -> None:
    """ament_copyright has no distribution: its test module is skipped by the tooling, not
    passed. Which tools are installed is part of the key, so the result is reused like any
    pass (issue 37: 38 of 62 upstream packages were retested every time), and the summary
    still names the linter."""
    (ws / "src" / "other" / "test" / "test_copyright.py").write_text(
        "from ament_copyright.main import main\n\n\n"
        "def test_copyright():\n    assert main(argv=['.', 'test']) == 0\n")
    first = _test(ws)
    assert first.returncode == 0, first.stdout + first.stderr
    assert "not installed, not run: ament_copyright (1 package): counted as skipped" \
        in first.stdout
    before = runs(ws)
    again = _test(ws)
    assert again.returncode == 0, again.stdout + again.stderr
    assert ran_since(ws, before) == []
    assert sorted(cached(again)) == ["cm", "leaf", "mid", "other", "root"]
    assert "not installed, not run: ament_copyright (1 package): counted as skipped" \
        in again.stdout


def test_a_test_fixture_in_a_directory_named_log_reruns_its_test(tmp_path: Path) -> None:
    """test/log/sample.log is the package's own file (no directory is skipped for its name):
    edited so that the test fails, the cached "passed" is not reused."""
    ws = tmp_path / "ws"
    pkg = write_package(ws / "src", "reader")
    (pkg / "test" / "log").mkdir(parents=True)
    (pkg / "test" / "log" / "sample.log").write_text("all ok\n")
    (pkg / "test" / "test_sample.py").write_text(
        "from pathlib import Path\n\n\ndef test_the_sample_says_ok():\n"
        "    assert 'ok' in (Path(__file__).parent / 'log' / 'sample.log').read_text()\n")
    _build(ws)
    assert _test(ws).returncode == 0
    assert "[reader] cached:" in _test(ws).stdout
    (pkg / "test" / "log" / "sample.log").write_text("all bad\n")
    failed = _test(ws)
    assert failed.returncode != 0 and "cached" not in failed.stdout, failed.stdout


def test_an_underlay_package_rebuilt_under_a_passing_test_reruns_it(tmp_path: Path) -> None:
    """An overlay's test imports a package of a chained underlay workspace: after the underlay
    is rebuilt so that the test fails, the cached "passed" is not reused."""
    under = tmp_path / "under"
    lib = write_package(under / "src", "under_lib")
    (lib / "under_lib" / "core.py").write_text("VALUE = 1\n")
    done = run_wsbuild("build", cwd=under, env=_env())
    assert done.returncode == 0, done.stdout + done.stderr
    ws = tmp_path / "ws"
    user = write_package(ws / "src", "over", kinds={"test_depend": ["under_lib"]})
    (user / "test").mkdir()
    (user / "test" / "test_under.py").write_text(
        "from under_lib.core import VALUE\n\n\ndef test_small():\n    assert VALUE < 3\n")
    sourced = subprocess.run(["bash", "-c", "source install/setup.bash && env -0"], cwd=under,
                             env=_env(), capture_output=True, text=True, check=True)
    env = dict(item.split("=", 1) for item in sourced.stdout.split("\0") if "=" in item)
    assert run_wsbuild("build", cwd=ws, env=env).returncode == 0
    assert run_wsbuild("test", cwd=ws, env=env).returncode == 0
    assert "[over] cached:" in run_wsbuild("test", cwd=ws, env=env).stdout

    (lib / "under_lib" / "core.py").write_text("VALUE = 5\n")
    assert run_wsbuild("build", cwd=under, env=_env()).returncode == 0
    again = run_wsbuild("test", cwd=ws, env=env)
    assert again.returncode != 0 and "cached" not in again.stdout, again.stdout
    log = sorted((ws / "log").glob("test_*"))[-1] / "over" / "command.log"
    assert "an underlay workspace's package it runs against changed" in log.read_text()


def test_the_dry_run_says_which_tests_would_run_and_why_in_the_dirty_checks_words(
        ws: Path) -> None:
    """`wsbuild test --dry-run` decides as the run decides, and words a rerun as
    `build --dry-run` words a build (`test: <why>`, record/tested.py's `Reason`); it runs
    nothing."""
    def decisions(result: subprocess.CompletedProcess[str]) -> dict[str, str]:
        assert result.returncode == 0, result.stdout + result.stderr
        return dict(re.findall(r"^\s+\d+\. (\w+)\s+(.*)$", result.stdout, re.MULTILINE))

    before = runs(ws)
    fresh = decisions(_test(ws, "--dry-run"))
    assert fresh == {name: "test: no passing result recorded"
                     for name in ("root", "other", "mid", "leaf", "cm")}
    assert runs(ws) == before  # nothing ran
    assert _test(ws).returncode == 0
    reuse = "reuse the last passing result: nothing its tests read changed"
    assert set(decisions(_test(ws, "--dry-run")).values()) == {reuse}
    with (ws / "src" / "other" / "test" / "test_counts.py").open("a") as handle:
        handle.write("\n# edited\n")
    planned = decisions(_test(ws, "--dry-run"))
    assert planned.pop("other") == "test: a file of the package changed"
    assert set(planned.values()) == {reuse}
    assert set(decisions(_test(ws, "--dry-run", "--no-test-cache")).values()) == \
        {"test: --no-test-cache"}
    before = runs(ws)
    done = _test(ws)
    assert done.returncode == 0 and ran_since(ws, before) == ["other"]
    log = (ws / "log" / "latest_test" / "other" / "command.log").read_text()
    assert "test result not reused: a file of the package changed" in log


def test_a_package_rebuilt_for_a_variable_its_build_read_runs_its_tests_again(
        tmp_path: Path) -> None:
    """The test key's `build` part: a package rebuilt because a variable its build read changed
    (none of its files did, nor any dependency) runs its tests again."""
    ws = tmp_path / "ws"
    cm = write_package(ws / "src", "cm", "cmake")
    (cm / "CMakeLists.txt").write_text(CM_CMAKELISTS.format().replace(
        "${RAN}", str(ws / "ran")).replace(
        "enable_testing()", 'enable_testing()\nfile(WRITE ${CMAKE_BINARY_DIR}/stamp.txt '
        '"$ENV{WSB_STAMP}")'))
    for stamp, ran in (("1", 1), ("1", 1), ("2", 2)):
        built = run_wsbuild("build", cwd=ws, env=_env(WSB_STAMP=stamp))
        assert built.returncode == 0, built.stdout + built.stderr
        tested = _test(ws, WSB_STAMP=stamp)
        assert tested.returncode == 0, tested.stdout + tested.stderr
        assert runs(ws) == {"cm": ran}, tested.stdout
