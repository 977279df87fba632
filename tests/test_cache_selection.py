"""colcon-cache's selection options on real workspaces: a package's build cache is invalid when
the plan of `wsbuild build` would build it, its test cache when, besides, its last tests did not
pass after its last build (verbs/cache_selection.py)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from conftest import SMALL_SPEC, run_wsbuild


def _names(*args: str, ws: Path) -> list[str]:
    done = run_wsbuild(*args, "-n", cwd=ws) if args[0] == "list" else run_wsbuild(*args, cwd=ws)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


def _started(output: str) -> list[str]:
    return [line.split()[-1] for line in output.splitlines() if line.startswith("Starting >>>")]


def test_build_and_list_select_what_the_plan_would_build(built: Path) -> None:
    ws = built
    assert _names("list", "--packages-select-cache-invalid", ws=ws) == []
    assert _names("list", "--packages-skip-cache-valid", ws=ws) == []
    # the answer depends on the plan: never replayed from a record
    assert not (ws / "build" / ".wsbuild" / "noop" / "list.json").exists()
    source = next((ws / "src" / "pa").rglob("main.py"))
    source.write_text(source.read_text() + "# changed\n")
    # pa changed; pb depends on it; pc is untouched
    assert _names("list", "--packages-select-cache-invalid", ws=ws) == ["pa", "pb"]
    assert _names("list", "--packages-skip-cache-valid", ws=ws) == ["pa", "pb"]
    graph = run_wsbuild("graph", "--packages-skip-cache-valid", cwd=ws).stdout
    assert [line for line in graph.splitlines() if not line.startswith(" ")] == ["pa", "pb"]
    info = run_wsbuild("info", "--packages-select-cache-invalid", cwd=ws)
    assert [line for line in info.stdout.splitlines() if not line.startswith(" ")] == \
        ["pa", "", "pb"]
    build = run_wsbuild("build", "--packages-skip-cache-valid", cwd=ws)
    assert build.returncode == 0, build.stderr
    # both selected; pb's build reads nothing of pa, so once pa is built it is cut off
    assert sorted(_started(build.stdout)) == ["pa"]
    assert "cut off (a dependency was rebuilt, nothing they build from changed): pb" \
        in build.stdout
    assert "pc" not in build.stdout
    assert _names("list", "--packages-select-cache-invalid", ws=ws) == []
    assert run_wsbuild("build", "--packages-select-cache-invalid", cwd=ws).returncode == 0


def test_builds_judge_by_their_own_options(built: Path) -> None:
    """Built with --symlink-install: a build with it finds everything valid, a plain list
    (which judges by a plain build) finds everything invalid."""
    ws = built
    assert run_wsbuild("build", "--symlink-install", cwd=ws).returncode == 0
    again = run_wsbuild("build", "--symlink-install", "--packages-select-cache-invalid", cwd=ws)
    assert again.returncode == 0 and _started(again.stdout) == []
    assert _names("list", "--packages-select-cache-invalid", ws=ws) == ["pa", "pb", "pc"]


def test_the_test_key_needs_tests_that_passed_after_the_last_build(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace(SMALL_SPEC)
    for name in ("pa", "pb"):
        tests = ws / "src" / name / "test"
        tests.mkdir()
        (tests / "test_it.py").write_text("def test_it():\n    assert True\n")
    assert run_wsbuild("build", cwd=ws).returncode == 0
    key = ("--packages-select-cache-key", "test")
    assert _names("list", "--packages-select-cache-invalid", *key, ws=ws) == ["pa", "pb", "pc"]
    tested = run_wsbuild("test", cwd=ws)
    assert tested.returncode == 0, tested.stdout + tested.stderr
    assert _names("list", "--packages-select-cache-invalid", *key, ws=ws) == ["pc"]
    # `wsbuild test` judges by the test cache unless told otherwise
    again = run_wsbuild("test", "--packages-skip-cache-valid", cwd=ws)
    assert again.returncode == 0, again.stdout + again.stderr
    assert _started(again.stdout) == ["pc"]
    (ws / "src" / "pb" / "test" / "test_it.py").write_text("def test_it():\n    assert 1\n")
    assert _names("list", "--packages-select-cache-invalid", *key, ws=ws) == ["pb", "pc"]


def test_the_two_options_exclude_each_other(built: Path) -> None:
    done = run_wsbuild("list", "--packages-select-cache-invalid", "--packages-skip-cache-valid",
                       cwd=built)
    assert done.returncode == 2 and "not allowed with argument" in done.stderr
    wrong = run_wsbuild("list", "--packages-select-cache-key", "lint", cwd=built)
    assert wrong.returncode == 2 and "'build', 'test'" in wrong.stderr
