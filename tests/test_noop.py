"""A no-op build decides every package in the main thread from stat calls and recorded state:
it starts no process and no thread, and still notices when the underlay changed."""

from __future__ import annotations

import os
import subprocess
import threading
from collections.abc import Callable
from pathlib import Path

import pytest
from conftest import (
    install_probe_distribution,
    needing_a_missing_distribution,
    run_wsbuild,
)

from wsbuild.cli import main

WARNING = "build dependencies not found"


def _no_processes_or_threads(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError(f"a no-op build started a process or thread: {args!r}")

    monkeypatch.setattr(subprocess.Popen, "__init__", refuse)
    monkeypatch.setattr(threading.Thread, "start", refuse)
    monkeypatch.setattr(os, "fork", refuse)
    monkeypatch.setattr(os, "posix_spawn", refuse)


def test_a_no_op_build_starts_no_process_and_no_thread(
        make_workspace: Callable[..., Path], monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    ws = make_workspace({"pa": ("ament_python", []), "pb": ("ament_python", ["pa"]),
                         "pc": ("cmake", []), "pd": ("ament_cmake", ["pc"])})
    first = run_wsbuild("build", cwd=ws)
    assert first.returncode == 0, first.stdout + first.stderr
    monkeypatch.chdir(ws)
    _no_processes_or_threads(monkeypatch)
    assert main(["build"]) == 0
    out = capsys.readouterr().out
    assert "4 packages up to date" in out, out


def test_an_underlay_change_is_noticed_by_the_next_build(tmp_path: Path) -> None:
    """The dependency check's result is remembered while its inputs hold: a distribution
    installed into a site directory after a build is seen by the next one."""
    ws, site = needing_a_missing_distribution(tmp_path)
    env = {**os.environ, "PYTHONPATH": str(site)}

    first = run_wsbuild("build", cwd=ws, env=env)
    assert first.returncode == 0 and WARNING in first.stdout + first.stderr
    again = run_wsbuild("build", cwd=ws, env=env)
    assert WARNING in again.stdout + again.stderr, "a remembered result is still reported"

    info = install_probe_distribution(site)
    installed = run_wsbuild("build", cwd=ws, env=env)
    assert installed.returncode == 0
    assert WARNING not in installed.stdout + installed.stderr, installed.stdout

    for path in sorted(info.iterdir()):
        path.unlink()
    info.rmdir()
    removed = run_wsbuild("build", cwd=ws, env=env)
    assert WARNING in removed.stdout + removed.stderr, "an uninstalled distribution is missed"
