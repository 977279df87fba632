"""The `wsbuild` command pip installs (bin/wsbuild): it starts the venv's interpreter once,
where the ROS wheels' bootstrapper (`ros_wheels_bootstrapper.pth`) makes `python -m wsbuild`
start it twice; from a symlink to it (pipx's) too."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from test_build_helpers import clean_env

VENV_BIN = Path(sys.executable).parent
#: an interpreter started: an execve of a program named python…
_PYTHON_STARTED = re.compile(r'execve\("[^"]*/python[0-9.]*"')


def _pythons_started(command: list[str], tmp_path: Path) -> tuple[int, str]:
    trace = tmp_path / "execs.txt"
    done = subprocess.run(["strace", "-f", "-qq", "-e", "trace=execve", "-o", str(trace),
                           *command, "--version"], env=clean_env(), capture_output=True,
                          text=True, timeout=120, check=True)
    return len(_PYTHON_STARTED.findall(trace.read_text())), done.stdout


def test_the_command_starts_the_interpreter_once_where_python_m_starts_it_twice(
        tmp_path: Path) -> None:
    site = next(Path(sys.prefix, "lib").glob("python3*/site-packages"))
    assert (site / "ros_wheels_bootstrapper.pth").is_file()  # what makes the second start
    assert _pythons_started([sys.executable, "-m", "wsbuild"], tmp_path)[0] == 2
    started, printed = _pythons_started([str(VENV_BIN / "wsbuild")], tmp_path)
    assert (started, printed.split()[0]) == (1, "wsbuild")
    linked = tmp_path / "bin" / "wsbuild"
    linked.parent.mkdir()
    linked.symlink_to(VENV_BIN / "wsbuild")
    started, printed = _pythons_started([str(linked)], tmp_path)
    assert (started, printed.split()[0]) == (1, "wsbuild")


def test_a_sourced_workspaces_search_paths_reach_the_steps_but_not_the_interpreters_start(
        tmp_path: Path) -> None:
    """A sourced workspace of many packages sets PYTHONPATH and LD_LIBRARY_PATH to an entry
    per package, which the interpreter's imports and the dynamic loader would search first at
    every start: the command starts the interpreter without them, and puts them back, so that
    what its steps see is what the user set."""
    from conftest import write_package

    libs, site_dir = tmp_path / "lib_a", tmp_path / "site_a"
    libs.mkdir()
    site_dir.mkdir()
    # a module on PYTHONPATH named as one the interpreter's start imports (site's own): the
    # sourced entries come after the interpreter's
    (site_dir / "_sitebuiltins.py").write_text("raise ImportError('the sourced path came first')\n")
    ws = tmp_path / "ws"
    package = write_package(ws / "src", "envprobe", "cmake")
    (package / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.14)\nproject(envprobe NONE)\n"
        'file(WRITE ${CMAKE_BINARY_DIR}/seen.txt "$ENV{LD_LIBRARY_PATH}\\n$ENV{PYTHONPATH}\\n")\n'
        "install(FILES package.xml DESTINATION share/envprobe)\n")
    env = clean_env(LD_LIBRARY_PATH=f"{libs}:/usr/lib", PYTHONPATH=f"{site_dir}:{tmp_path}")
    trace = tmp_path / "execs.txt"
    done = subprocess.run(["strace", "-f", "-qq", "-v", "-s", "4096", "-e", "trace=execve",
                           "-o", str(trace), str(VENV_BIN / "wsbuild"), "build"], cwd=ws,
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    seen_ld, seen_python = (ws / "build" / "envprobe" / "seen.txt").read_text().splitlines()
    assert f"{libs}:/usr/lib" in seen_ld
    assert f"{site_dir}:{tmp_path}" in seen_python
    started = next(line for line in trace.read_text().splitlines()
                   if _PYTHON_STARTED.search(line))
    assert '"LD_LIBRARY_PATH="' in started and '"PYTHONPATH="' in started, started
