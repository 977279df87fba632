"""wsbuild as a user installs it: the sdist and the wheel built from a copy of the checkout with
`python -m build`, the wheel installed with its `ros` extra into a fresh virtualenv outside the
checkout, and from there `pkg create` (a Python node, a C++ library), `deps install -y`,
`build`, running the node, and `test` — no other command, nothing of the checkout used."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tarfile
import time
import zipfile
from collections.abc import Mapping
from pathlib import Path

import pytest

from conftest import REPO
from test_build_helpers import clean_env, output

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("install_wheel")]

#: top-level folders of the checkout the copy leaves out (a venv, build output, git itself)
_LEFT_OUT = (".git", ".venv", "build", "install", "log", "dist")


def copy_checkout(target: Path) -> Path:
    """The checkout's files as git sees them (tracked and untracked, not ignored)."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others",
                             "--exclude-standard"], cwd=REPO, capture_output=True, check=True)
    for name in sorted(set(listed.stdout.decode().split("\0")) - {""}):
        source = REPO / name
        if name.split("/")[0] in _LEFT_OUT or not source.is_file():
            continue
        destination = target / name
        destination.parent.mkdir(parents=True, exist_ok=True)
        destination.write_bytes(source.read_bytes())
        destination.chmod(source.stat().st_mode & 0o777)
    return target


def run(command: list[str], *, cwd: Path, env: Mapping[str, str],
        timeout: float = 900) -> subprocess.CompletedProcess[str]:
    return subprocess.run(command, cwd=cwd, env=dict(env), capture_output=True, text=True,
                          timeout=timeout, check=False)


def timed(times: dict[str, float], step: str, command: list[str], *, cwd: Path,
          env: Mapping[str, str], timeout: float = 900) -> subprocess.CompletedProcess[str]:
    started = time.monotonic()
    done = run(command, cwd=cwd, env=env, timeout=timeout)
    times[step] = time.monotonic() - started
    assert done.returncode == 0, f"{step}:\n{output(done)}"
    return done


@pytest.fixture(scope="module")
def dist(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`python -m build` of a copy of the checkout: the sdist, and the wheel built from it."""
    source = copy_checkout(tmp_path_factory.mktemp("wsbuild-src"))
    out = tmp_path_factory.mktemp("dist")
    built = run([sys.executable, "-m", "build", "--outdir", str(out), "."], cwd=source,
                env=clean_env())
    assert built.returncode == 0, output(built)
    return out


def test_the_wheel_installs_and_runs_pkg_create_build_and_test_outside_the_checkout(
        dist: Path, tmp_path: Path) -> None:
    times: dict[str, float] = {}
    (sdist,) = dist.glob("wsbuild-*.tar.gz")
    (wheel,) = dist.glob("wsbuild-*-py3-none-any.whl")

    with tarfile.open(sdist) as archive:
        names = [n.split("/", 1)[1] for n in archive.getnames() if "/" in n]
    assert "LICENSE" in names and "requirements/ros-jazzy.lock.txt" in names
    assert not [n for n in names if n.startswith("tests/")]  # it could not run them
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        license_text = archive.read("wsbuild-0.1.0.dist-info/licenses/LICENSE").decode()
    assert "wsbuild/requirements/ros-jazzy.lock.txt" in names
    assert "wsbuild/requirements/ros-pytest.txt" in names
    assert "Apache License" in license_text and "Version 2.0" in license_text

    user = tmp_path / "user"  # nothing of the checkout below here
    venv = user / "ros"
    timed(times, "python -m venv", [sys.executable, "-m", "venv", str(venv)], cwd=user.parent,
          env=clean_env())
    env = clean_env(VIRTUAL_ENV=str(venv), XDG_CACHE_HOME=str(user / "cache"),
                    PATH=f"{venv / 'bin'}{os.pathsep}{os.environ['PATH']}")
    env.pop("PYTHONPATH", None)
    timed(times, "pip install wheel[ros]",
          [str(venv / "bin" / "python"), "-m", "pip", "install", f"{wheel}[ros]"],
          cwd=user, env=env)
    ws = user / "ws"
    (ws / "src").mkdir(parents=True)
    wsbuild = str(venv / "bin" / "wsbuild")
    timed(times, "pkg create (Python node)",
          [wsbuild, "pkg", "create", "talker_py", "--build-type", "ament_python",
           "--dependencies", "rclpy", "--node-name", "talker", "--license", "Apache-2.0"],
          cwd=ws, env=env)
    timed(times, "pkg create (C++ library)",
          [wsbuild, "pkg", "create", "greeter_cpp", "--library-name", "greeter",
           "--license", "Apache-2.0"], cwd=ws, env=env)

    installed = timed(times, "deps install -y", [wsbuild, "deps", "install", "-y"], cwd=ws,
                      env=env)
    lock = venv.glob("lib/python3*/site-packages/wsbuild/requirements/ros-jazzy.lock.txt")
    assert f" -c {next(lock)} -- " in installed.stdout  # the shipped constraints, by default
    assert "the ROS tests' pytest" in installed.stdout
    assert "nothing is missing" in installed.stdout
    named = [word for word in installed.stdout.split() if word.endswith(".txt")]
    assert named and all(Path(word).is_file() for word in named), named  # no checkout paths

    timed(times, "build", [wsbuild, "build"], cwd=ws, env=env)

    started = time.monotonic()
    node = subprocess.Popen([wsbuild, "run", "talker_py", "talker"], cwd=ws, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    try:
        assert node.stdout is not None
        seen = ""
        for line in node.stdout:  # the node logs its greeting once it is up
            seen += line
            if "greeting: Hello from talker" in line:
                break
        times["run the node (until it logs)"] = time.monotonic() - started
        assert "greeting: Hello from talker" in seen, seen
        node.send_signal(signal.SIGINT)
        assert node.wait(timeout=60) == 0
    finally:
        if node.poll() is None:
            os.killpg(node.pid, signal.SIGKILL)
            node.wait()

    tested = timed(times, "test", [wsbuild, "test"], cwd=ws, env=env)
    assert "greeter_cpp" in tested.stdout and "talker_py" in tested.stdout
    result = run([wsbuild, "test-result"], cwd=ws, env=env)
    assert result.returncode == 0, output(result)
    print("\n".join(f"{step}: {seconds:.1f} s" for step, seconds in times.items()))


def test_pipx_installs_the_wheel_and_its_venv_is_the_underlay(dist: Path, tmp_path: Path) -> None:
    (wheel,) = dist.glob("wsbuild-*-py3-none-any.whl")
    home, bin_dir = tmp_path / "pipx", tmp_path / "bin"
    env = clean_env(PIPX_HOME=str(home), PIPX_BIN_DIR=str(bin_dir),
                    XDG_CACHE_HOME=str(tmp_path / "cache"),
                    PATH=f"{bin_dir}{os.pathsep}{os.environ['PATH']}")
    env.pop("VIRTUAL_ENV", None)
    env.pop("PYTHONPATH", None)
    pipx = run([sys.executable, "-m", "pipx", "install", f"{wheel}[ros]"], cwd=tmp_path, env=env)
    assert pipx.returncode == 0, output(pipx)
    wsbuild = str(bin_dir / "wsbuild")
    ws = tmp_path / "ws"
    (ws / "src").mkdir(parents=True)
    for command in (["pkg", "create", "hello_cpp", "--library-name", "hello"],
                    ["deps", "install", "-y"], ["build"], ["test"]):
        done = run([wsbuild, *command], cwd=ws, env=env)
        assert done.returncode == 0, f"wsbuild {' '.join(command)}:\n{output(done)}"
    # the underlay is pipx's own virtualenv, and deps installed into it
    assert f"underlay {home / 'venvs' / 'wsbuild'}" in run([wsbuild, "deps"], cwd=ws,
                                                           env=env).stdout
