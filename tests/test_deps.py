"""`wsbuild deps` with real installers, in one virtualenv of this session that starts with only
`wsbuild[ros]` (made from pip's cache with the project's lock file as constraint).

The tests share that virtualenv and run in file order on one xdist worker: the corpus first
(from only `wsbuild[ros]` to a complete build), then a missing wheel and Python key, bad input,
`build --install-deps`, and rosdep's rules last (they install rosdep).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path

import pytest

from conftest import REPO, run_wsbuild, write_package
from test_build_helpers import REQUIRES_ROS, clean_env, output

pytestmark = [*REQUIRES_ROS, pytest.mark.slow, pytest.mark.xdist_group("deps")]

LOCK = REPO / "requirements" / "ros-jazzy.lock.txt"
CORPUS = Path(__file__).parent / "data" / "corpus" / "src"
#: corpus keys needed only at run time that have no wheel and no rule anywhere (see the test)
CORPUS_ABSENT = ("turtlesim", "launch_ros", "robot_state_publisher")


@pytest.fixture(scope="session")
def venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A virtualenv holding only `wsbuild[ros]` (no system site-packages)."""
    path = tmp_path_factory.mktemp("deps") / "venv"
    env = clean_env()
    made = subprocess.run([sys.executable, "-m", "venv", str(path)], env=env,
                          capture_output=True, text=True, check=False)
    assert made.returncode == 0, made.stderr
    pip = subprocess.run([str(path / "bin" / "python"), "-m", "pip", "install", "-q",
                          "-c", str(LOCK), "-e", f"{REPO}[ros]"],
                         env=env, capture_output=True, text=True, timeout=900, check=False)
    assert pip.returncode == 0, pip.stderr[-2000:]
    return path


def venv_env(venv: Path, **extra: str) -> dict[str, str]:
    """A fresh terminal with `venv` activated."""
    return clean_env(VIRTUAL_ENV=str(venv), PATH=f"{venv / 'bin'}{os.pathsep}{os.environ['PATH']}",
                     **extra)


def deps(venv: Path, *args: str, cwd: Path, env: Mapping[str, str] | None = None,
         timeout: float = 900) -> subprocess.CompletedProcess[str]:
    """The venv's own `wsbuild ARGS`, as a user of that venv types it."""
    return subprocess.run([str(venv / "bin" / "wsbuild"), *args], cwd=cwd,
                          env=dict(env or venv_env(venv)), capture_output=True, text=True,
                          timeout=timeout, check=False)


def freeze(venv: Path) -> list[str]:
    done = subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "freeze"],
                          env=venv_env(venv), capture_output=True, text=True, check=True)
    return sorted(done.stdout.splitlines())


def line_with(text: str, *parts: str) -> str:
    """The one line of `text` holding every part (a readable failure otherwise)."""
    lines = [line for line in text.splitlines() if all(p in line for p in parts)]
    assert lines, f"no line with {parts} in:\n{text}"
    return lines[0]


# --------------------------------------------------------------------------- the corpus


def test_corpus_goes_from_wsbuild_ros_only_to_a_complete_build(venv: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    shutil.copytree(CORPUS, ws / "src")
    check = deps(venv, "deps", "check", cwd=ws)
    assert check.returncode == 1, output(check)
    text = check.stdout
    # each missing key with the source that installs it
    assert "ROS wheel: pip ros-jazzy-geometry-msgs" in line_with(text, "missing: geometry_msgs")
    assert "Python key by convention: pip psutil" in line_with(text, "missing: python3-psutil")
    assert "pip importlib-metadata" in line_with(text, "missing: python3-importlib-metadata")
    assert "pip pytest" in line_with(text, "missing: python3-pytest")
    # what the venv has already is not listed: yaml, lark, numpy, packaging, argcomplete, xacro
    for present in ("python3-yaml", "python3-lark-parser", "python3-numpy", "python3-packaging",
                    "python3-argcomplete", "xacro", "std_msgs"):
        assert f" {present} (" not in text, text
    assert "ament_lint_auto" in line_with(text, "stood in for by wsbuild")
    for absent in CORPUS_ABSENT:
        assert "no ros-jazzy-" in line_with(text, f"unresolved: {absent} (")

    skip = ["--skip-keys", *CORPUS_ABSENT]
    installed = deps(venv, "deps", "install", "-y", "--constraint", str(LOCK), *skip, cwd=ws)
    assert installed.returncode == 0, output(installed)
    assert "nothing is missing" in installed.stdout

    built = deps(venv, "build", cwd=ws, timeout=1500)
    assert built.returncode == 0, output(built)
    assert deps(venv, "deps", "check", *skip, cwd=ws).returncode == 0
    # the run-time key works at run time: the ros2cli-style verb imports psutil
    ran = deps(venv, "run", "corpus_py_cli", "corpus_cli", "processes", "python", cwd=ws)
    assert ran.returncode == 0 and "python" in ran.stdout, output(ran)


# ----------------------------------------------------------- a missing wheel and Python key


@pytest.fixture
def needy(tmp_path: Path) -> Path:
    """A workspace whose package needs sensor_msgs and python3-tabulate, which the venv lacks."""
    ws = tmp_path / "ws"
    write_package(ws / "src", "needy", "ament_python", ["rclpy", "sensor_msgs"],
                  kinds={"exec_depend": ["python3-tabulate"]})
    return ws


def test_missing_wheel_and_python_key_are_listed_planned_installed_and_built(
        venv: Path, needy: Path) -> None:
    # deps check and the build's warning agree: same lookup, same keys of the build types
    warned = deps(venv, "build", cwd=needy)
    assert warned.returncode == 0, output(warned)
    assert "sensor_msgs: pip install ros-jazzy-sensor-msgs" in warned.stdout + warned.stderr
    build_keys = deps(venv, "deps", "check", "--types", "build", cwd=needy)
    assert [line.split()[1] for line in build_keys.stdout.splitlines()
            if line.startswith("  missing:")] == ["sensor_msgs"], output(build_keys)

    check = deps(venv, "deps", "check", cwd=needy)
    assert check.returncode == 1, output(check)
    assert "-> ROS wheel: pip ros-jazzy-sensor-msgs" in line_with(check.stdout, "sensor_msgs (")
    assert "-> Python key by convention: pip tabulate" in line_with(check.stdout,
                                                                    "python3-tabulate (")

    before = freeze(venv)
    planned = deps(venv, "deps", "install", "--dry-run", "--constraint", str(LOCK), cwd=needy)
    assert planned.returncode == 0, output(planned)
    assert freeze(venv) == before
    command = line_with(planned.stdout, "$ ")
    assert command.split("$ ", 1)[1] == (f"{venv}/bin/python3 -m pip install -c {LOCK} "
                                         "-- tabulate ros-jazzy-sensor-msgs")
    assert "sensor_msgs -> ros-jazzy-sensor-msgs  (ROS wheel" in planned.stdout

    installed = deps(venv, "deps", "install", "-y", "--constraint", str(LOCK), cwd=needy)
    assert installed.returncode == 0, output(installed)
    after = freeze(venv)
    assert any(line.startswith("ros-jazzy-sensor-msgs==") for line in after)
    assert any(line.lower().startswith("tabulate==") for line in after)

    built = deps(venv, "build", cwd=needy)
    assert built.returncode == 0, output(built)
    assert "warning" not in (built.stdout + built.stderr).lower(), output(built)


# ------------------------------------------------------------------------------ bad input


def test_unknown_keys_and_missing_wheels_are_named_with_why(venv: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_package(ws / "src", "odd", "ament_python", [],
                  kinds={"exec_depend": ["wsbuild_no_such_pkg", "python3-wsbuild-no-such-dist",
                                         "std_msg"]})
    before = freeze(venv)
    result = deps(venv, "deps", "install", "-y", cwd=ws)
    assert result.returncode == 1, output(result)
    line = line_with(result.stdout, "unresolved: wsbuild_no_such_pkg (needed by odd")
    assert "no ros-jazzy-wsbuild-no-such-pkg wheel" in line and "rosdep" in line
    line = line_with(result.stdout, "unresolved: python3-wsbuild-no-such-dist (needed by odd")
    assert "no Python distribution wsbuild-no-such-dist" in line
    line = line_with(result.stdout, "unresolved: std_msg (needed by odd")
    assert "did you mean 'std_msgs'?" in line  # a misspelling, not a missing package
    assert freeze(venv) == before


def test_pip_failing_against_an_empty_index_installs_nothing(venv: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_package(ws / "src", "offline", "ament_python", ["std_srvs"],
                  kinds={"exec_depend": ["python3-wsbuild-offline"]})
    empty = tmp_path / "empty-index"
    empty.mkdir()
    env = venv_env(venv, PIP_INDEX_URL=empty.as_uri(), PIP_CONFIG_FILE=os.devnull,
                   PIP_FIND_LINKS="", PIP_EXTRA_INDEX_URL="", PIP_NO_CACHE_DIR="1",
                   PIP_RETRIES="0")
    before = freeze(venv)
    result = deps(venv, "deps", "install", "-y", cwd=ws, env=env)
    assert result.returncode == 1, output(result)
    error = line_with(result.stderr, "wsbuild: error: std_srvs: pip ros-jazzy-std-srvs failed")
    assert "ros-jazzy-std-srvs" in error and "ERROR:" in error
    assert "unresolved: python3-wsbuild-offline" in result.stdout
    assert freeze(venv) == before
    # nothing half-installed: the next look sees the same as before
    again = deps(venv, "deps", "check", cwd=ws)
    assert "missing: std_srvs" in again.stdout, output(again)


def test_a_missing_constraints_file_is_a_usage_error(venv: Path, needy: Path) -> None:
    result = deps(venv, "deps", "install", "--constraint", "nope.txt", cwd=needy)
    assert result.returncode == 2
    assert result.stderr.startswith("wsbuild: error: nope.txt: the constraints file does not "
                                    "exist"), output(result)


def test_build_install_deps_from_a_defaults_file(venv: Path, tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_package(ws / "src", "srv_user", "ament_python", ["std_srvs"])
    (ws / "wsbuild.yaml").write_text("build:\n  install-deps: true\n")
    built = deps(venv, "build", cwd=ws, env=venv_env(venv, PIP_CONSTRAINT=str(LOCK)))
    assert built.returncode == 0, output(built)
    assert "std_srvs -> ros-jazzy-std-srvs" in built.stdout
    assert "warning" not in (built.stdout + built.stderr).lower(), output(built)
    assert any(line.startswith("ros-jazzy-std-srvs==") for line in freeze(venv))


def test_build_install_deps_lists_the_keys_it_could_not_install(tmp_path: Path) -> None:
    """Nothing to install is no reason for silence: the keys no source has are listed, as
    `wsbuild deps` lists them (this session's own venv: nothing here can be installed)."""
    ws = tmp_path / "ws"
    write_package(ws / "src", "odd_user", "ament_python", [],
                  kinds={"exec_depend": ["wsbuild_no_such_pkg"]})
    built = run_wsbuild("build", "--install-deps", cwd=ws, env=clean_env())
    assert built.returncode == 0, output(built)
    line = line_with(built.stdout, "unresolved: wsbuild_no_such_pkg (needed by odd_user")
    assert "no ros-jazzy-wsbuild-no-such-pkg wheel" in line


#: apt-get on a machine without cppcheck, as near as a test can make one: the real cppcheck is
#: installed (scripts/setup.sh) and only hidden from the test's PATH, so "installing" the
#: package puts the program back on that PATH; every other package is refused
HIDING_APT = """\
#!/bin/sh
echo "apt-get $*" >> '@LOG@'
value=
for arg in "$@"; do
  if [ -n "$value" ]; then value=; continue; fi
  case "$arg" in
    -o) value=1 ;;
    -*|install) ;;
    cppcheck) ln -sf /usr/bin/cppcheck '@BIN@/cppcheck' ;;
    *) echo "E: Unable to locate package $arg" >&2; exit 100 ;;
  esac
done
"""


def test_a_new_users_first_day_passes_on_a_machine_without_cppcheck(venv: Path,
                                                                     tmp_path: Path) -> None:
    """Issue 37's first day, in a virtualenv holding only wsbuild[ros]: a C++ package (library
    and node) and a Python one from `pkg create`, `deps install -y`, `build`, `test`. The C++
    package's linters run cppcheck, which no wheel brings: deps installs it with apt-get."""
    hidden = tmp_path / "bin"  # the machine's programs, less cppcheck
    hidden.mkdir()
    for directory in ("/usr/local/bin", "/usr/bin", "/bin", "/usr/sbin", "/sbin"):
        for entry in sorted(Path(directory).iterdir()) if Path(directory).is_dir() else ():
            if entry.name != "cppcheck" and not (hidden / entry.name).exists():
                (hidden / entry.name).symlink_to(entry)
    log = tmp_path / "apt.log"
    (hidden / "apt-get").unlink(missing_ok=True)
    (hidden / "apt-get").write_text(HIDING_APT.replace("@LOG@", str(log))
                                    .replace("@BIN@", str(hidden)))
    (hidden / "apt-get").chmod(0o755)
    env = venv_env(venv)
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{hidden}"
    ws = tmp_path / "ws"
    (ws / "src").mkdir(parents=True)
    for create in (["demo_cpp", "--library-name", "demo", "--node-name", "demo_node"],
                   ["demo_py", "--build-type", "ament_python", "--node-name", "demo_talker"]):
        made = deps(venv, "pkg", "create", *create, cwd=ws, env=env)
        assert made.returncode == 0, output(made)

    checked = deps(venv, "deps", cwd=ws, env=env)
    line_with(checked.stdout, "missing: cppcheck (needed by demo_cpp", "apt cppcheck")
    installed = deps(venv, "deps", "install", "-y", cwd=ws, env=env)
    assert installed.returncode == 0, output(installed)
    assert "install -y --no-install-recommends -- cppcheck" in log.read_text()
    built = deps(venv, "build", cwd=ws, env=env)
    assert built.returncode == 0, output(built)
    tested = deps(venv, "test", cwd=ws, env=env)
    assert tested.returncode == 0, output(tested)
    assert " 0 errors, 0 failures" in tested.stdout, output(tested)
    ran = deps(venv, "run", "demo_cpp", "demo_node", cwd=ws, env=env)
    assert "Hello, demo_cpp!" in ran.stdout, output(ran)  # the node calls its library


# -------------------------------------------------------------------------- rosdep's rules

RULES = """\
wsbuild-test-hello:
  debian: [hello]
  ubuntu: [hello]
wsbuild-test-termcolor:
  debian:
    pip:
      packages: [termcolor]
  ubuntu:
    pip:
      packages: [termcolor]
"""

INDEX = """\
%YAML 1.1
---
distributions: {}
type: index
version: 4
"""


def _apt(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["apt-get", *args], capture_output=True, text=True, check=False,
                          env=dict(os.environ, DEBIAN_FRONTEND="noninteractive"), timeout=600)


def _installed(package: str) -> bool:
    done = subprocess.run(["dpkg-query", "-W", "-f=${Status}", package], capture_output=True,
                          text=True, check=False)
    return done.stdout.endswith(" installed")


@pytest.fixture
def rosdep_env(venv: Path, tmp_path: Path) -> Iterator[dict[str, str]]:
    """rosdep in the venv, its rules from a local YAML file (`rosdep update` against it), and
    GNU hello not installed but known to apt."""
    pip = subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "install", "-q", "-c",
                          str(LOCK), "rosdep"], env=venv_env(venv), capture_output=True,
                         text=True, check=False, timeout=600)
    assert pip.returncode == 0, pip.stderr[-2000:]
    (tmp_path / "rules.yaml").write_text(RULES)
    (tmp_path / "index.yaml").write_text(INDEX)
    sources = tmp_path / "sources.list.d"
    sources.mkdir()
    (sources / "10-test.list").write_text(f"yaml {(tmp_path / 'rules.yaml').as_uri()}\n")
    env = venv_env(venv, ROSDEP_SOURCE_PATH=str(sources), ROS_HOME=str(tmp_path / "ros_home"),
                   ROSDISTRO_INDEX_URL=(tmp_path / "index.yaml").as_uri())
    update = subprocess.run([str(venv / "bin" / "rosdep"), "update"], env=env,
                            capture_output=True, text=True, check=False, timeout=300)
    assert update.returncode == 0, output(update)
    if _installed("hello"):
        assert _apt("remove", "-y", "-qq", "hello").returncode == 0
    if _apt("install", "-y", "-qq", "--simulate", "hello").returncode != 0:
        assert _apt("update", "-qq").returncode == 0
    yield env
    _apt("remove", "-y", "-qq", "hello")


def test_rosdep_rules_install_pip_entries_and_apt_only_with_yes(
        venv: Path, tmp_path: Path, rosdep_env: dict[str, str]) -> None:
    assert os.geteuid() == 0, "CI runs as root: the real apt-get install needs it"
    ws = tmp_path / "ws"
    write_package(ws / "src", "sysdeps", "cmake", [],
                  kinds={"exec_depend": ["wsbuild-test-hello", "wsbuild-test-termcolor"]})
    check = deps(venv, "deps", "check", cwd=ws, env=rosdep_env)
    assert check.returncode == 1, output(check)
    assert "rosdep: rules for " in check.stdout
    assert "-> rosdep: apt hello" in line_with(check.stdout, "missing: wsbuild-test-hello")
    assert "-> rosdep: pip termcolor" in line_with(check.stdout, "missing: wsbuild-test-termcolor")

    # without -y: the venv's pip runs, apt-get does not; its exact command is printed
    held = deps(venv, "deps", "install", cwd=ws, env=rosdep_env)
    assert held.returncode == 1, output(held)
    error = line_with(held.stderr, "wsbuild: error: wsbuild-test-hello")
    assert "apt-get runs only with -y" in error
    assert error.endswith("run it yourself: apt-get install -y --no-install-recommends -- hello")
    assert not _installed("hello")
    assert any(line.lower().startswith("termcolor==") for line in freeze(venv))

    done = deps(venv, "deps", "install", "-y", cwd=ws, env=rosdep_env)
    assert done.returncode == 0, output(done)
    assert _installed("hello") and shutil.which("hello") is not None
    after = deps(venv, "deps", "check", cwd=ws, env=rosdep_env)
    assert after.returncode == 0, output(after)
    assert "wsbuild-test-hello, wsbuild-test-termcolor" in line_with(
        after.stdout, "installed as rosdep's rules say")


def test_a_key_rosdep_does_not_know_is_unresolved(venv: Path, tmp_path: Path,
                                                   rosdep_env: dict[str, str]) -> None:
    ws = tmp_path / "ws"
    write_package(ws / "src", "strange", "cmake", [],
                  kinds={"exec_depend": ["wsbuild-unknown-key"]})
    result = deps(venv, "deps", "install", "-y", cwd=ws, env=rosdep_env)
    assert result.returncode == 1, output(result)
    assert "rosdep has no rule for wsbuild-unknown-key" in line_with(
        result.stdout, "unresolved: wsbuild-unknown-key (needed by strange")
