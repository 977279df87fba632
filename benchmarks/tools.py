"""The two tools under test: the project's wsbuild and colcon from PyPI in a venv of its own, same underlay."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_PROJECT_VENV = REPO / ".venv"
DEFAULT_COLCON_VENV = Path.home() / ".cache" / "wsbuild-bench" / "colcon-venv"
#: what a user installs (colcon-core, colcon-ros, colcon-cmake, colcon-bash, ...)
COLCON_REQUIREMENT = "colcon-common-extensions"
#: the .pth that lets colcon's interpreter import the underlay's Python packages
UNDERLAY_PTH = "wsbuild_bench_underlay.pth"

#: variables of the caller that would make one tool see another workspace or underlay
_SCRUB = ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "COLCON_PREFIX_PATH", "PYTHONPATH",
          "VIRTUAL_ENV", "ROS_DISTRO", "ROS_VERSION", "ROS_PYTHON_VERSION", "COLCON_HOME",
          "_ROS_WHEELS_BOOTSTRAP_COMPLETE", "LD_LIBRARY_PATH", "COLCON_DEFAULTS_FILE",
          "COLCON_LOG_PATH",
          # not a user's default: both tools byte-compile what they install
          "PYTHONDONTWRITEBYTECODE", "PYTHONUNBUFFERED")


class SetupError(RuntimeError):
    """The benchmark cannot run (missing venv, failed install)."""


def _site_packages(venv: Path) -> Path:
    found = sorted((venv / "lib").glob("python3*/site-packages"))
    if not found:
        raise SetupError(f"{venv}: no lib/python3*/site-packages (not a virtualenv?)")
    return found[0]


def clean_environ(environ: Mapping[str, str] | None = None) -> dict[str, str]:
    """The caller's environment without anything ROS/workspace related."""
    env = {k: v for k, v in (environ or os.environ).items() if k not in _SCRUB}
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.setdefault("ROS_DOMAIN_ID", "87")
    return env


@dataclass(frozen=True, slots=True)
class Tools:
    """How to run each tool, and the environment each one gets."""

    project_venv: Path
    colcon_venv: Path
    #: environment for wsbuild: clean, wsbuild finds the venv underlay itself (as a user runs it)
    wsbuild_env: dict[str, str]
    #: environment for colcon: clean + what `wsbuild.underlay.environment.build_environment` computes
    colcon_env: dict[str, str]
    #: a fresh terminal (no venv activated): where `source install/setup.bash` is timed
    shell_env: dict[str, str]

    @property
    def wsbuild(self) -> Path:
        return self.project_venv / "bin" / "wsbuild"

    @property
    def colcon(self) -> Path:
        return self.colcon_venv / "bin" / "colcon"

    def wsbuild_cmd(self, *args: str) -> list[str]:
        return [str(self.wsbuild), *args]

    def colcon_cmd(self, *args: str) -> list[str]:
        return [str(self.colcon), *args]


def _run(cmd: Sequence[str], **kwargs: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(list(cmd), text=True, capture_output=True, **kwargs)  # type: ignore[call-overload]


def ensure_colcon_venv(colcon_venv: Path, project_venv: Path, log: Log) -> None:
    """Create the colcon venv if missing: `<project python> -m venv --system-site-packages`,
    `pip install colcon-common-extensions`, then a .pth that puts the project venv's
    site-packages (the ROS wheels, catkin_pkg, ament_package) after colcon's own.

    `--system-site-packages` alone is not enough: a venv made from a venv's interpreter gets
    the *base* interpreter's site-packages, not the project venv's.  The .pth is written after
    pip ran, so pip installs colcon's dependencies into the colcon venv instead of considering
    them satisfied by (or trying to upgrade) the project venv's copies.
    """
    python = project_venv / "bin" / "python"
    if not python.exists():
        raise SetupError(f"{python} does not exist: run scripts/setup.sh first")
    colcon = colcon_venv / "bin" / "colcon"
    if not colcon.exists():
        log(f"creating the colcon venv in {colcon_venv} (once; --colcon-venv to move it)")
        colcon_venv.parent.mkdir(parents=True, exist_ok=True)
        done = _run([str(python), "-m", "venv", "--system-site-packages", str(colcon_venv)])
        if done.returncode != 0:
            raise SetupError(f"python -m venv failed:\n{done.stderr}")
        pip = [str(colcon_venv / "bin" / "python"), "-m", "pip", "install", "-q"]
        done = _run([*pip, "--upgrade", "pip"])
        done = _run([*pip, COLCON_REQUIREMENT])
        if done.returncode != 0:
            raise SetupError(f"pip install {COLCON_REQUIREMENT} failed:\n{done.stderr}")
    # colcon runs setup.py with its own interpreter: give it the project's setuptools, so the
    # two tools differ in how they drive setuptools, not in which setuptools they drive
    want = _setuptools_version(python)
    if _setuptools_version(colcon_venv / "bin" / "python") != want:
        log(f"installing setuptools=={want} (the project venv's) into the colcon venv")
        done = _run([str(colcon_venv / "bin" / "python"), "-m", "pip", "install", "-q",
                     f"setuptools=={want}"])
        if done.returncode != 0:
            raise SetupError(f"pip install setuptools=={want} failed:\n{done.stderr}")
    pth = _site_packages(colcon_venv) / UNDERLAY_PTH
    text = str(_site_packages(project_venv)) + "\n"
    if not pth.is_file() or pth.read_text() != text:
        pth.write_text(text)


def setup_tools(project_venv: Path, colcon_venv: Path, log: Log) -> Tools | None:
    """Both tools, the colcon venv made first if missing; None (the reason printed) when that
    fails. Every benchmark's main starts here."""
    try:
        ensure_colcon_venv(colcon_venv, project_venv, log)
    except SetupError as exc:
        print(f"benchmark setup failed: {exc}", file=sys.stderr)
        return None
    return make_tools(project_venv.resolve(), colcon_venv.resolve())


def _setuptools_version(python: Path) -> str:
    done = _run([str(python), "-c", "import importlib.metadata as m; print(m.version('setuptools'))"],
                env={**clean_environ(), "_ROS_WHEELS_BOOTSTRAP_COMPLETE": "1"})
    return done.stdout.strip()


def make_tools(project_venv: Path, colcon_venv: Path) -> Tools:
    """Both tools' environments.  colcon's gets the underlay variables exactly as wsbuild
    computes them for its own builds (`wsbuild.underlay.environment.build_environment`)."""
    from wsbuild.underlay.environment import build_environment

    base = clean_environ()
    path = [p for p in base.get("PATH", "").split(os.pathsep)
            if p and Path(p).resolve() != (project_venv / "bin").resolve()]
    base["PATH"] = os.pathsep.join(path)
    colcon_env = dict(base)
    colcon_env.update(build_environment(project_venv, base))
    # wsbuild as the README's quickstart runs it: in the activated project venv
    wsbuild_env = dict(base)
    wsbuild_env["VIRTUAL_ENV"] = str(project_venv)
    wsbuild_env["PATH"] = os.pathsep.join([str(project_venv / "bin"), *path])
    # full builds must build: the build cache would restore repeats (benchmarks/cache.py
    # measures the cache and turns it back on)
    wsbuild_env["WSBUILD_CACHE"] = "off"
    return Tools(project_venv=project_venv, colcon_venv=colcon_venv,
                 wsbuild_env=wsbuild_env, colcon_env=colcon_env, shell_env=dict(base))


class Log:
    """Progress lines on stderr (the table goes to stdout)."""

    def __init__(self, quiet: bool = False) -> None:
        self.quiet = quiet

    def __call__(self, text: str) -> None:
        if not self.quiet:
            print(f"[bench] {text}", file=sys.stderr, flush=True)


def _first_line(cmd: Sequence[str], env: Mapping[str, str] | None = None) -> str:
    try:
        done = _run(cmd, env=dict(env) if env is not None else None, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"
    text = (done.stdout or done.stderr).strip()
    return text.splitlines()[0] if text else "unknown"


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def machine_details(tools: Tools) -> dict[str, str]:
    """CPU count and model, OS, Python, cmake, colcon (core/ros/cmake) and wsbuild versions."""
    colcon_python = str(tools.colcon_venv / "bin" / "python")
    versions = _first_line([colcon_python, "-c", (
        "import importlib.metadata as m; print(' '.join(f'{n} {m.version(n)}' for n in "
        "('colcon-core', 'colcon-ros', 'colcon-cmake', 'colcon-python-setup-py', 'setuptools')))"
    )], tools.colcon_env)
    setuptools_ws = _first_line([str(tools.project_venv / "bin" / "python"), "-c",
                                 "import setuptools; print(setuptools.__version__)"],
                                tools.colcon_env)
    return {
        "CPUs": str(os.cpu_count()),
        "CPU model": cpu_model(),
        "OS": _first_line(["uname", "-srm"]),
        "Python": _first_line([str(tools.project_venv / "bin" / "python"), "--version"],
                              tools.colcon_env),
        "cmake": _first_line(["cmake", "--version"]),
        "wsbuild": _first_line([str(tools.wsbuild), "--version"], tools.wsbuild_env)
        + f" (setuptools {setuptools_ws})",
        "colcon": versions,
        "platform": sysconfig.get_platform(),
    }


def write_section(path: Path, begin: str, end: str, section: str) -> None:
    """Replace the part of `path` between the markers `begin` and `end` with `section` (which
    carries both markers); append it the first time. The rest of the file is kept."""
    text = path.read_text(encoding="utf-8") if path.is_file() else ""
    if begin in text and end in text:
        before, rest = text.split(begin, 1)
        text = before + section.rstrip("\n") + rest.split(end, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + section
    path.write_text(text, encoding="utf-8")
