"""Building a wheel through a package's PEP 517 backend, without build isolation."""

from __future__ import annotations

import os
import shutil
from collections.abc import Mapping
from pathlib import Path

from wsbuild.build_types import CommandRunner, StepFailed
from wsbuild.build_types.pybuild.setup_py import BuildSystem

#: the script the target interpreter runs; it must not import wsbuild
HOOK_SCRIPT = Path(__file__).with_name("pep517_hook.py")


def build_wheel(source_dir: Path, build_dir: Path, build_system: BuildSystem, *, run: CommandRunner,
                environ: Mapping[str, str], python_executable: str,
                setup_requires_known_empty: bool = False) -> Path:
    """Build the package's wheel into `build_dir/wheel` and return its path.

    Like colcon (and `pip --no-build-isolation`), the backend and its requirements come from
    the environment; a missing one is reported by name. For setuptools, `egg_info` and `build`
    are pointed at `build_dir` so that nothing is written into the source directory, and
    `setup_requires_known_empty` spares the extra setup.py run that asks for build
    requirements.
    """
    # the backend runs in the source directory: every path handed to it must be absolute
    source_dir, build_dir = source_dir.absolute(), build_dir.absolute()
    wheel_dir = build_dir / "wheel"
    if wheel_dir.exists():
        shutil.rmtree(wheel_dir)
    wheel_dir.mkdir(parents=True)
    env = dict(environ)
    if build_system.is_setuptools:
        env["DIST_EXTRA_CONFIG"] = str(_setuptools_config(source_dir, build_dir))
        for stale in build_dir.glob("*.egg-info"):
            shutil.rmtree(stale)
    command = [python_executable, str(HOOK_SCRIPT), build_system.backend, str(wheel_dir)]
    for path in build_system.backend_path:
        command += ["--backend-path", path]
    for requirement in build_system.requires:
        command += ["--requires", requirement]
    if build_system.is_setuptools and setup_requires_known_empty:
        command.append("--no-setup-requires")
    run(command, cwd=source_dir, env=env)
    wheels = sorted(wheel_dir.glob("*.whl"))
    if len(wheels) != 1:
        raise StepFailed(f"the build backend {build_system.backend} left {len(wheels)} wheels "
                         f"in {wheel_dir} (expected one)")
    return wheels[0]


def _setuptools_config(source_dir: Path, build_dir: Path) -> Path:
    # setuptools reads this file (DIST_EXTRA_CONFIG) after setup.cfg, so it wins. egg_base is
    # relative like colcon's `--egg-base`, which keeps SOURCES.txt identical to the fast path.
    egg_base = os.path.relpath(os.path.realpath(build_dir), os.path.realpath(source_dir))
    text = (f"[egg_info]\negg_base = {egg_base}\n\n"
            f"[build]\nbuild_base = {build_dir / 'build'}\n")
    path = build_dir / "setuptools.cfg"
    if not path.is_file() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")
    return path
