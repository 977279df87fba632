"""Staged installs: the previous install survives failures; stale files disappear."""

from __future__ import annotations

from pathlib import Path

import pytest

from wsbuild.prefix.stage import (
    commit_isolated, commit_merged, direct_install, new_stage, recover_all, STAGE_DIR,
)


def test_commit_isolated_replaces_the_whole_prefix(tmp_path: Path) -> None:
    prefix = tmp_path / "install" / "pkg"
    (prefix / "old").mkdir(parents=True)
    (prefix / "old" / "stale.txt").write_text("old")
    stage = new_stage(tmp_path / "install", "pkg")
    (stage / "new.txt").write_text("new")
    commit_isolated(stage, prefix)
    assert sorted(p.name for p in prefix.iterdir()) == ["new.txt"]
    assert not stage.exists()


def test_commit_merged_removes_only_this_packages_stale_files(tmp_path: Path) -> None:
    install = tmp_path / "install"
    (install / "share" / "other").mkdir(parents=True)
    (install / "share" / "other" / "keep.txt").write_text("other package")
    record = tmp_path / "build" / "pkg" / "record.txt"
    stage = new_stage(install, "pkg")
    (stage / "share" / "pkg").mkdir(parents=True)
    (stage / "share" / "pkg" / "a.txt").write_text("1")
    (stage / "share" / "pkg" / "b.txt").write_text("1")
    commit_merged(stage, install, record)
    stage = new_stage(install, "pkg")
    (stage / "share" / "pkg").mkdir(parents=True)
    (stage / "share" / "pkg" / "a.txt").write_text("2")
    commit_merged(stage, install, record)
    assert (install / "share" / "pkg" / "a.txt").read_text() == "2"
    assert not (install / "share" / "pkg" / "b.txt").exists()
    assert (install / "share" / "other" / "keep.txt").exists()


def test_direct_install_failure_restores_previous_install(tmp_path: Path) -> None:
    prefix = tmp_path / "install" / "pkg"
    prefix.mkdir(parents=True)
    (prefix / "v1.txt").write_text("v1")
    stage = new_stage(tmp_path / "install", "pkg")
    with pytest.raises(RuntimeError):
        with direct_install(prefix, stage):
            (prefix / "half.txt").write_text("partial")
            raise RuntimeError("install failed")
    assert sorted(p.name for p in prefix.iterdir()) == ["v1.txt"]


def test_direct_install_success_moves_result_to_stage(tmp_path: Path) -> None:
    prefix = tmp_path / "install" / "pkg"
    prefix.mkdir(parents=True)
    (prefix / "v1.txt").write_text("v1")
    stage = new_stage(tmp_path / "install", "pkg")
    with direct_install(prefix, stage):
        (prefix / "v2.txt").write_text("v2")
    assert sorted(p.name for p in stage.iterdir()) == ["v2.txt"]
    assert sorted(p.name for p in prefix.iterdir()) == ["v1.txt"]  # until committed


def test_recover_all_puts_back_an_install_parked_by_a_killed_run(tmp_path: Path) -> None:
    install = tmp_path / "install"
    parked = install / STAGE_DIR / "pkg.previous"
    parked.mkdir(parents=True)
    (parked / "good.txt").write_text("previous")
    (install / "pkg").mkdir()
    (install / "pkg" / "half.txt").write_text("partial")
    recover_all(install)
    assert sorted(p.name for p in (install / "pkg").iterdir()) == ["good.txt"]
    assert not (install / STAGE_DIR).exists()
