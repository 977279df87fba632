"""`wsbuild deps` with real pip against the package index, in a small virtualenv of its own
(wsbuild with rosdistro and vcstool, and one ROS wheel, `ros-jazzy-ament-package`, which makes
it a Jazzy underlay): a ROS package PyPI carries under its own project gets installed and
imports; a key that looks like an option reaches no installer; the index's answers are
remembered; the ROS tests' pytest comes with the dependencies; `--from-source` fetches from
local git repositories named by a local index in REP 153's format."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from collections.abc import Mapping
from pathlib import Path

import pytest

import yaml

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
                          "-c", str(LOCK), "-e", str(REPO), "ros-jazzy-ament-package",
                          "rosdistro", "vcstool"],
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

    # a constraints file of the user's replaces the one wsbuild ships
    mine = tmp_path / "mine.txt"
    mine.write_text("osrf-pycommon>=2\n")
    planned = wsbuild(venv, "deps", "install", "--dry-run", "--constraint", str(mine), cwd=ws)
    assert f"-m pip install -c {mine} -- osrf-pycommon" in planned.stdout, output(planned)

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
    cache = tmp_path / "cache"  # wsbuild's cache directory (the build cache's rule)
    first = wsbuild(venv, "deps", cwd=ws, env=venv_env(venv, WSBUILD_CACHE_DIR=str(cache)))
    assert first.returncode == 1, output(first)
    wanted = ("missing: urdfdom_py (needed by described: exec_depend) -> ROS package on PyPI: "
              "pip urdfdom-py")
    assert wanted in first.stdout, output(first)
    assert (cache / "deps" / "index-answers.json").is_file()

    # pip can no longer reach the index (a proxy nobody listens on): the answers come from memory
    offline = venv_env(venv, WSBUILD_CACHE_DIR=str(cache), PIP_PROXY="http://127.0.0.1:9",
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


# ------------------------------------------------------------------------- from source


def git_repository(path: Path, packages: dict[str, list[str]], branch: str = "jazzy",
                   broken: dict[str, list[str]] | None = None) -> str:
    """A git repository holding ament_python packages {name: exec_depends}, and `broken`
    CMake packages {name: depends} whose configure needs each of their depends; its file://
    URL."""
    for name, exec_depends in packages.items():
        write_package(path, name, "ament_python", [], kinds={"exec_depend": exec_depends})
    for name, depends in (broken or {}).items():
        package = write_package(path, name, "cmake", depends)
        (package / "CMakeLists.txt").write_text(
            f"cmake_minimum_required(VERSION 3.14)\nproject({name} NONE)\n"
            + "".join(f"find_package({d} REQUIRED)\n" for d in depends))
    git = ["git", "-c", "user.name=upstream", "-c", "user.email=upstream@example.invalid"]
    for command in (["init", "-q", "-b", branch], ["add", "-A"], ["commit", "-q", "-m", "v1"]):
        subprocess.run([*git, *command], cwd=path, check=True, capture_output=True)
    return path.as_uri()


def rosdistro_index(root: Path, repositories: dict[str, tuple[str, list[str]]]) -> Path:
    """An index-v4.yaml with a Jazzy distribution.yaml (format 2, as ros/rosdistro writes
    them) releasing {repository: (source URL, packages)}."""
    (root / "jazzy").mkdir(parents=True)
    (root / "index-v4.yaml").write_text(textwrap.dedent("""\
        %YAML 1.1
        # ROS index file
        # see REP 153: http://ros.org/reps/rep-0153.html
        ---
        distributions:
          jazzy:
            distribution: [jazzy/distribution.yaml]
            distribution_cache: http://127.0.0.1:9/jazzy-cache.yaml.gz
            distribution_status: active
            distribution_type: ros2
            python_version: 3
        type: index
        version: 4
        """))
    entries = {
        name: {
            "release": {"packages": packages,
                        "tags": {"release": "release/jazzy/{package}/{version}"},
                        "url": f"https://example.invalid/{name}-release.git",
                        "version": "1.0.0-1"},
            "source": {"type": "git", "url": url, "version": "jazzy"},
            "status": "developed",
        }
        for name, (url, packages) in repositories.items()
    }
    distribution = {"release_platforms": {"rhel": ["9"], "ubuntu": ["noble"]},
                    "repositories": entries, "type": "distribution", "version": 2}
    (root / "jazzy" / "distribution.yaml").write_text(
        "%YAML 1.1\n# ROS distribution file\n# see REP 143: "
        "http://ros.org/reps/rep-0143.html\n---\n" + yaml.safe_dump(distribution))
    return root / "index-v4.yaml"


def test_from_source_fetches_what_no_installer_has_and_its_dependencies_in_turn(
        venv: Path, tmp_path: Path) -> None:
    upstream = tmp_path / "upstream"
    # a repository of two packages (like ros2/launch), the first needing a package of a second
    # repository and a key PyPI carries; a third repository nobody needs
    # (its wsb_test_msgs, which nothing here needs, cannot build here, as ros2's test_msgs
    # without its test_interface_files; its std_msgs would shadow the wheel of that name)
    core = git_repository(upstream / "wsb_launch_core",
                          {"wsb_launch": ["wsb_launch_dep", "urdfdom_py"],
                           "wsb_launch_xml": ["wsb_launch"]},
                          broken={"wsb_test_msgs": ["wsb_test_interface_files"],
                                  "std_msgs": ["wsb_no_such_thing"]})
    dep = git_repository(upstream / "wsb_dep_repo", {"wsb_launch_dep": []})
    unused = git_repository(upstream / "wsb_unused", {"wsb_unused": []})
    index = rosdistro_index(tmp_path / "rosdistro", {
        "wsb_launch_core": (core, ["wsb_launch", "wsb_launch_xml"]),
        "wsb_dep_repo": (dep, ["wsb_launch_dep"]),
        "wsb_unused": (unused, ["wsb_unused"]),
    })
    ws = tmp_path / "ws"
    write_package(ws / "src", "my_app", "ament_python", [],
                  kinds={"exec_depend": ["wsb_launch", "wsb_nowhere"]})
    env = venv_env(venv, ROSDISTRO_INDEX_URL=index.as_uri())

    check = wsbuild(venv, "deps", cwd=ws, env=env)
    assert check.returncode == 1, output(check)
    assert f"sources: index {index.as_uri()}" in check.stdout.splitlines()[0]
    available = line_with(check.stdout, "available from source: wsb_launch (needed by my_app)")
    assert f"-> repository wsb_launch_core ({core} jazzy)" in available
    nowhere = line_with(check.stdout, "unresolved: wsb_nowhere (")
    assert "from source: not released in the jazzy index" in nowhere
    planned = wsbuild(venv, "deps", "install", "--dry-run", cwd=ws, env=env)
    assert f"  wsb_launch_core: {core} jazzy  (for wsb_launch)" in planned.stdout, output(planned)
    # the plan was made: a dry run exits 0 though wsb_nowhere stays unresolved, unless --strict
    assert planned.returncode == 0, output(planned)
    strict = wsbuild(venv, "deps", "install", "--dry-run", "--strict", cwd=ws, env=env)
    assert strict.returncode == 1 and strict.stdout == planned.stdout, output(strict)
    # without --from-source, install fetches nothing and says how
    held = wsbuild(venv, "deps", "install", "-y", "--skip-keys", "wsb_nowhere", cwd=ws, env=env)
    assert held.returncode == 1 and not (ws / "src" / "wsb_launch_core").exists(), output(held)
    assert "wsbuild deps install --from-source fetches them" in held.stderr

    fetched = wsbuild(venv, "deps", "install", "-y", "--from-source", "--skip-keys",
                      "wsb_nowhere", cwd=ws, env=env)
    assert fetched.returncode == 0, output(fetched)
    assert "installed: urdfdom_py (urdfdom-py)" in fetched.stdout
    # wsb_launch_xml and the others came with wsb_launch's repository, but nothing needs them:
    # left out of the build, and named
    assert ("from source: left out of the build, as nothing here needs them (a COLCON_IGNORE "
            "in each; remove it to build one): std_msgs, wsb_launch_xml, wsb_test_msgs"
            in fetched.stdout), output(fetched)
    assert "nothing is missing" in fetched.stdout
    for name in ("wsb_launch_core", "wsb_dep_repo"):  # the second one for wsb_launch's own key
        assert (ws / "src" / name / ".git").is_dir(), output(fetched)
    assert not (ws / "src" / "wsb_unused").exists()
    assert imports(venv, "urdf_parser_py")  # wsb_launch's key from PyPI, in the same run
    repos = yaml.safe_load((ws / "from-source.repos").read_text())
    assert repos == {"repositories": {
        "wsb_dep_repo": {"type": "git", "url": dep, "version": "jazzy"},
        "wsb_launch_core": {"type": "git", "url": core, "version": "jazzy"},
    }}
    # the .repos file is what vcstool's import takes: it fetches the same into another workspace
    again = tmp_path / "again"
    (again / "src").mkdir(parents=True)
    imported = subprocess.run(
        [str(venv / "bin" / "vcs-import"), "--input", str(ws / "from-source.repos"), "src"],
        cwd=again, env=env, capture_output=True, text=True, check=False)
    assert imported.returncode == 0, output(imported)
    assert sorted(p.name for p in (again / "src").iterdir()) == ["wsb_dep_repo",
                                                                 "wsb_launch_core"]

    built = wsbuild(venv, "build", cwd=ws, env=env)  # a plain build, as deps said nothing else
    assert built.returncode == 0, output(built)
    assert sorted(p.name for p in (ws / "install").iterdir() if p.is_dir()) == [
        "my_app", "wsb_launch", "wsb_launch_dep"]  # std_msgs stays the wheel's
    ran = wsbuild(venv, "run", "wsb_launch", "wsb_launch_main", cwd=ws, env=env)
    assert ran.returncode == 0 and "hello from wsb_launch" in ran.stdout, output(ran)
    assert wsbuild(venv, "deps", "--skip-keys", "wsb_nowhere", cwd=ws, env=env).returncode == 0


def test_a_source_entry_that_is_no_git_url_is_never_cloned(venv: Path, tmp_path: Path) -> None:
    index = rosdistro_index(tmp_path / "rosdistro", {
        "wsb_odd": ("--upload-pack=touch /tmp/pwned", ["wsb_odd"])})
    ws = tmp_path / "ws"
    write_package(ws / "src", "my_app", "ament_python", [], kinds={"exec_depend": ["wsb_odd"]})
    env = venv_env(venv, ROSDISTRO_INDEX_URL=index.as_uri())
    result = wsbuild(venv, "deps", "install", "-y", "--from-source", cwd=ws, env=env)
    assert result.returncode == 1, output(result)
    assert ("from source: the source URL '--upload-pack=touch /tmp/pwned' is not a git URL"
            in line_with(result.stdout, "unresolved: wsb_odd ("))
    assert sorted(p.name for p in (ws / "src").iterdir()) == ["my_app"]


#: a CMake package in the pattern of rclcpp and libstatistics_collector: its tests need
#: packages released elsewhere (mimick_vendor, performance_test_fixture), found only under
#: BUILD_TESTING; it installs a marker its users find
RCLCPP_LIKE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
include(CTest)
{finds}
if(BUILD_TESTING)
{test_finds}
endif()
file(WRITE ${{CMAKE_CURRENT_BINARY_DIR}}/{name}Config.cmake "set({name}_FOUND TRUE)\\n")
install(FILES ${{CMAKE_CURRENT_BINARY_DIR}}/{name}Config.cmake DESTINATION share/{name}/cmake)
"""


def cmake_repository(path: Path, packages: dict[str, tuple[list[str], list[str]]]) -> str:
    """A git repository of CMake packages {name: (depends, test_depends)} in rclcpp's pattern
    (RCLCPP_LIKE); its file:// URL."""
    for name, (depends, test_depends) in packages.items():
        package = write_package(path, name, "cmake", depends,
                                kinds={"test_depend": test_depends})
        (package / "CMakeLists.txt").write_text(RCLCPP_LIKE.format(
            name=name, finds="".join(f"find_package({d} REQUIRED)\n" for d in depends),
            test_finds="".join(f"  find_package({d} REQUIRED)\n" for d in test_depends)))
    git = ["git", "-c", "user.name=upstream", "-c", "user.email=upstream@example.invalid"]
    for command in (["init", "-q", "-b", "jazzy"], ["add", "-A"], ["commit", "-q", "-m", "v1"]):
        subprocess.run([*git, *command], cwd=path, check=True, capture_output=True)
    return path.as_uri()


def test_from_source_fetches_an_rclcpp_like_stack_without_its_test_dependencies(
        venv: Path, tmp_path: Path) -> None:
    """rclcpp's pattern: a user's node needs `wsb_rclcpp`, which needs
    `wsb_statistics_collector` (another repository), which needs `wsb_statistics_msgs` (a
    third); both test with packages released nowhere the index says. `deps install
    --from-source` fetches the three repositories and not the test dependencies, and the plain
    `wsbuild build` that follows builds them with their tests off, then the node."""
    upstream = tmp_path / "upstream"
    rclcpp = cmake_repository(upstream / "wsb_rclcpp_repo", {"wsb_rclcpp": (
        ["wsb_statistics_collector"], ["wsb_google_benchmark", "wsb_mimick_vendor",
                                       "wsb_performance_test_fixture"])})
    collector = cmake_repository(upstream / "wsb_collector_repo", {"wsb_statistics_collector": (
        ["wsb_statistics_msgs"], ["wsb_performance_test_fixture"])})
    interfaces = cmake_repository(upstream / "wsb_interfaces_repo",
                                  {"wsb_statistics_msgs": ([], [])})
    index = rosdistro_index(tmp_path / "rosdistro", {
        "wsb_rclcpp_repo": (rclcpp, ["wsb_rclcpp"]),
        "wsb_collector_repo": (collector, ["wsb_statistics_collector"]),
        "wsb_interfaces_repo": (interfaces, ["wsb_statistics_msgs"]),
    })
    ws = tmp_path / "ws"
    node = write_package(ws / "src", "cpp_pubsub", "cmake", ["wsb_rclcpp"])
    (node / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.14)\nproject(cpp_pubsub NONE)\n"
        "find_package(wsb_rclcpp REQUIRED)\ninstall(FILES package.xml DESTINATION share)\n")
    env = venv_env(venv, ROSDISTRO_INDEX_URL=index.as_uri())

    fetched = wsbuild(venv, "deps", "install", "-y", "--from-source", cwd=ws, env=env)
    assert fetched.returncode == 0, output(fetched)
    assert sorted(p.name for p in (ws / "src").iterdir()) == [
        "cpp_pubsub", "wsb_collector_repo", "wsb_interfaces_repo", "wsb_rclcpp_repo"]
    assert "performance_test_fixture" not in fetched.stdout + fetched.stderr, output(fetched)
    assert ("from source: built with their tests off (-DBUILD_TESTING=OFF in colcon.meta): "
            in fetched.stdout), output(fetched)
    assert (ws / "colcon.meta").is_file()
    assert wsbuild(venv, "deps", cwd=ws, env=env).returncode == 0  # nothing left missing

    built = wsbuild(venv, "build", cwd=ws, env=env)
    assert built.returncode == 0, output(built)
    assert sorted(p.name for p in (ws / "install").iterdir() if p.is_dir()) == [
        "cpp_pubsub", "wsb_rclcpp", "wsb_statistics_collector", "wsb_statistics_msgs"]
