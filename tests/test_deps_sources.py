"""`wsbuild deps` with real pip against the package index, in a small virtualenv of its own
(wsbuild and one ROS wheel, `ros-jazzy-ament-package`, which makes it a Jazzy underlay): a ROS
package PyPI carries under its own project gets installed and imports; a key that looks like an
option reaches no installer."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

import pytest

from conftest import REPO, write_package
from test_build_helpers import clean_env, output

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("deps_sources")]

LOCK = REPO / "requirements" / "ros-jazzy.lock.txt"


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """wsbuild (editable, no extras) and ros-jazzy-ament-package, nothing else of ROS."""
    path = tmp_path_factory.mktemp("deps_sources") / "venv"
    env = clean_env()
    made = subprocess.run([sys.executable, "-m", "venv", str(path)], env=env,
                          capture_output=True, text=True, check=False)
    assert made.returncode == 0, made.stderr
    pip = subprocess.run([str(path / "bin" / "python"), "-m", "pip", "install", "-q",
                          "-c", str(LOCK), "-e", str(REPO), "ros-jazzy-ament-package"],
                         env=env, capture_output=True, text=True, timeout=900, check=False)
    assert pip.returncode == 0, pip.stderr[-2000:]
    return path


def venv_env(venv: Path, **extra: str) -> dict[str, str]:
    """A fresh terminal with `venv` activated (the index's answers remembered beside it)."""
    extra.setdefault("XDG_CACHE_HOME", str(venv.parent / "cache"))
    return clean_env(VIRTUAL_ENV=str(venv), PATH=f"{venv / 'bin'}{os.pathsep}{os.environ['PATH']}",
                     **extra)


def wsbuild(venv: Path, *args: str, cwd: Path, env: Mapping[str, str] | None = None,
            ) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(venv / "bin" / "wsbuild"), *args], cwd=cwd,
                          env=dict(env or venv_env(venv)), capture_output=True, text=True,
                          timeout=900, check=False)


def imports(venv: Path, module: str) -> bool:
    done = subprocess.run([str(venv / "bin" / "python"), "-c", f"import {module}"],
                          env=venv_env(venv), capture_output=True, text=True, check=False)
    return done.returncode == 0


def line_with(text: str, *parts: str) -> str:
    lines = [line for line in text.splitlines() if all(p in line for p in parts)]
    assert lines, f"no line with {parts} in:\n{text}"
    return lines[0]


def test_osrf_pycommon_is_installed_from_its_pypi_project_and_an_option_like_key_is_refused(
        venv: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    # python3--h would be the distribution `-h` by convention: pip's help, not a package
    write_package(ws / "src", "launcher", "ament_python", [],
                  kinds={"exec_depend": ["osrf_pycommon", "python3--h"]})
    assert not imports(venv, "osrf_pycommon.process_utils")

    check = wsbuild(venv, "deps", cwd=ws)
    assert check.returncode == 1, output(check)
    assert "-> ROS package on PyPI: pip osrf-pycommon" in line_with(check.stdout,
                                                                    "missing: osrf_pycommon (")
    refused = line_with(check.stdout, "unresolved: python3--h (")
    assert "'-h' is not a PEP 508 requirement, so wsbuild does not hand it to pip" in refused

    installed = wsbuild(venv, "deps", "install", "-y", cwd=ws)
    assert installed.returncode == 1, output(installed)  # python3--h stays unresolved
    assert "installed: osrf_pycommon (osrf-pycommon)" in installed.stdout, output(installed)
    assert "Usage:" not in installed.stdout + installed.stderr  # pip never printed its help
    # constrained by the lock file wsbuild ships for Jazzy, the names after `--`
    assert (f"$ {venv}/bin/python3 -m pip install -c {LOCK} -- osrf-pycommon"
            in installed.stdout), output(installed)
    assert imports(venv, "osrf_pycommon.process_utils")

    again = wsbuild(venv, "deps", "--skip-keys", "python3--h", cwd=ws)
    assert again.returncode == 0, output(again)
    assert "nothing is missing" in again.stdout


def test_index_answers_are_remembered_until_refresh(venv: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_package(ws / "src", "described", "ament_python", [],
                  kinds={"exec_depend": ["urdfdom_py"]})
    cache = tmp_path / "cache"
    first = wsbuild(venv, "deps", cwd=ws, env=venv_env(venv, XDG_CACHE_HOME=str(cache)))
    assert first.returncode == 1, output(first)
    wanted = "missing: urdfdom_py (needed by described: exec_depend) -> ROS package on PyPI: pip urdfdom-py"
    assert wanted in first.stdout, output(first)
    assert (cache / "wsbuild" / "deps" / "index-answers.json").is_file()

    # pip can no longer reach the index (a proxy nobody listens on): the answers come from memory
    offline = venv_env(venv, XDG_CACHE_HOME=str(cache), PIP_PROXY="http://127.0.0.1:9",
                       PIP_RETRIES="0")
    second = wsbuild(venv, "deps", cwd=ws, env=offline)
    assert second.stdout == first.stdout, output(second)

    refreshed = wsbuild(venv, "deps", "--refresh", cwd=ws, env=offline)
    assert refreshed.returncode == 1, output(refreshed)
    assert "no PyPI project urdfdom-py" in line_with(refreshed.stdout, "unresolved: urdfdom_py (")


def test_the_ros_tests_pytest_comes_with_the_dependencies(venv: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    package = write_package(ws / "src", "tested", "ament_python", [])
    (package / "test").mkdir()
    (package / "test" / "test_one.py").write_text("def test_one():\n    assert True\n")
    target = venv / "ros-pytest"
    assert not target.exists()

    check = wsbuild(venv, "deps", cwd=ws)
    assert check.returncode == 1, output(check)
    assert (f"missing: pytest==7.4.4 for the tests of tested -> the ROS tests' pytest: pip into "
            f"{target}") in check.stdout
    # tests not wanted: not missing
    assert wsbuild(venv, "deps", "--types", "build,run", cwd=ws).returncode == 0

    installed = wsbuild(venv, "deps", "install", "-y", cwd=ws)
    assert installed.returncode == 0, output(installed)
    assert (target / "pytest-7.4.4.dist-info").is_dir()
    assert "nothing is missing" in wsbuild(venv, "deps", cwd=ws).stdout
