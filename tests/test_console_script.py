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
