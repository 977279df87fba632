"""Shared helpers of the `wsbuild build` integration tests (test_build_*.py); holds no tests."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import textwrap
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TypeVar

import pytest

from conftest import PACKAGE_XML, run_wsbuild
from wsbuild.underlay.detect import find_venv_underlay

PY = sys.executable

#: variables a sourced workspace or the wheels' bootstrapper set: tests start without them,
#: like a fresh terminal
_SOURCED_VARS = (
    "AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "COLCON_PREFIX_PATH", "COLCON_CURRENT_PREFIX",
    "LD_LIBRARY_PATH", "PYTHONPATH", "PKG_CONFIG_PATH", "VIRTUAL_ENV", "ROS_DISTRO",
    "ROS_VERSION", "ROS_PYTHON_VERSION", "_ROS_WHEELS_BOOTSTRAP_COMPLETE", "COLCON_TRACE",
)

#: a DDS domain of these tests' own (nothing here starts a node, but be safe)
ROS_DOMAIN_ID = "87"


def ros_underlay() -> Path | None:
    """The ROS 2 wheel virtualenv the tests run in, if any."""
    return find_venv_underlay(os.environ, sys.executable)


#: apply as `pytestmark = REQUIRES_ROS` or `@requires_ros`
REQUIRES_ROS = [
    pytest.mark.ros,
    pytest.mark.skipif(ros_underlay() is None,
                       reason="needs the ROS 2 Jazzy wheel underlay in the running virtualenv"),
]


F = TypeVar("F", bound=Callable[..., object])


def requires_ros(func: F) -> F:
    for mark in REQUIRES_ROS:
        func = mark(func)
    return func


def clean_env(**extra: str) -> dict[str, str]:
    """The environment of a fresh terminal: nothing sourced, DDS kept on this machine."""
    env = {k: v for k, v in os.environ.items() if k not in _SOURCED_VARS}
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_DOMAIN_ID"] = ROS_DOMAIN_ID
    env.update(extra)
    return env


def wsbuild(*args: str, cwd: Path, env: Mapping[str, str] | None = None,
            timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """`python -m wsbuild ARGS` in a fresh terminal's environment."""
    return run_wsbuild(*args, cwd=cwd, env=clean_env() if env is None else env, timeout=timeout)


def build(ws: Path, *args: str,
          env: Mapping[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """`wsbuild build ARGS` that must succeed."""
    result = wsbuild("build", *args, cwd=ws, env=env)
    assert result.returncode == 0, output(result)
    return result


def output(result: subprocess.CompletedProcess[str]) -> str:
    return f"exit {result.returncode}\n--- stdout\n{result.stdout}\n--- stderr\n{result.stderr}"


def shell(script: str, *, cwd: Path, shell: str = "bash", env: Mapping[str, str] | None = None,
          timeout: float = 120, strict: bool = True) -> subprocess.CompletedProcess[str]:
    """Run `script` in a fresh `shell` (bash, dash or zsh), as a user would; `strict` adds
    `set -u` (wsbuild's scripts must cope with it; colcon's do not)."""
    full_env = dict(clean_env() if env is None else env)
    full_env["WSBUILD_TEST_PYTHON"] = PY
    return subprocess.run([shell, "-c", ("set -u\n" if strict else "") + script], cwd=cwd,
                          env=full_env, capture_output=True, text=True, timeout=timeout)


def sourced(ws: Path, script: str, *, shell_name: str = "bash", cwd: Path | None = None,
            env: Mapping[str, str] | None = None,
            strict: bool = True) -> subprocess.CompletedProcess[str]:
    """Run `script` after sourcing `ws`/install/setup.<shell>; the script must succeed."""
    ext = {"bash": "bash", "zsh": "zsh", "dash": "sh", "sh": "sh"}[shell_name]
    setup = ws / "install" / f"setup.{ext}"
    # errexit only after sourcing: setup scripts need not be written for it
    result = shell(f". {sh_quote(str(setup))}\nset -e\n{script}", cwd=cwd or ws, shell=shell_name,
                   env=env, strict=strict)
    assert result.returncode == 0, output(result)
    return result


def sh_quote(text: str) -> str:
    return "'" + text.replace("'", "'\"'\"'") + "'"


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


def package_xml(name: str, build_type: str, *, depend: Sequence[str] = (),
                buildtool: Sequence[str] = (), exec_depend: Sequence[str] = (),
                build_depend: Sequence[str] = ()) -> str:
    tags = [f"  <buildtool_depend>{d}</buildtool_depend>" for d in buildtool]
    tags += [f"  <depend>{d}</depend>" for d in depend]
    tags += [f"  <build_depend>{d}</build_depend>" for d in build_depend]
    tags += [f"  <exec_depend>{d}</exec_depend>" for d in exec_depend]
    return PACKAGE_XML.format(name=name, version="0.1.0", deps="\n".join(tags),
                              build_type=build_type)


AMENT_PYTHON_SETUP = """\
import os
from glob import glob
from setuptools import find_packages, setup

package_name = {name!r}

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
{data_files}    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Dev',
    maintainer_email='dev@example.com',
    description='Test package',
    license='Apache-2.0',
    entry_points={{'console_scripts': [{scripts}]}},
)
"""


def write_ament_python(src: Path, name: str, *, modules: Mapping[str, str],
                       data: Mapping[str, str] | None = None,
                       scripts: Mapping[str, str] | None = None,
                       depend: Sequence[str] = (), exec_depend: Sequence[str] = ()) -> Path:
    """An ament_python package like `ros2 pkg create` makes: `modules` are files of the Python
    package, `data` files (relative paths such as launch/x.launch.py) are installed to
    share/<name>/<their directory> through globs, `scripts` are console scripts."""
    pkg = src / name
    write(pkg / "package.xml", package_xml(name, "ament_python", depend=depend,
                                           exec_depend=exec_depend))
    write(pkg / "resource" / name, "")
    write(pkg / "setup.cfg", f"""
        [develop]
        script_dir=$base/lib/{name}
        [install]
        install_scripts=$base/lib/{name}
        """)
    write(pkg / name / "__init__.py", "")
    for rel, text in modules.items():
        write(pkg / name / rel, text)
    data = data or {}
    for rel, text in data.items():
        write(pkg / rel, text)
    dirs = sorted({str(Path(rel).parent) for rel in data})
    data_lines = "".join(
        f"        (os.path.join('share', package_name, {d!r}), glob({d + '/*'!r})),\n"
        for d in dirs)
    script_items = ", ".join(f"'{s} = {target}'" for s, target in (scripts or {}).items())
    write(pkg / "setup.py", AMENT_PYTHON_SETUP.format(name=name, data_files=data_lines,
                                                      scripts=script_items))
    return pkg


def write_cmake(src: Path, name: str, cmakelists: str, *, build_type: str | None = "cmake",
                depend: Sequence[str] = (), buildtool: Sequence[str] = (),
                files: Mapping[str, str] | None = None) -> Path:
    """A CMake package; `build_type=None` writes no package.xml (a plain CMake project)."""
    pkg = src / name
    write(pkg / "CMakeLists.txt", cmakelists)
    if build_type is not None:
        write(pkg / "package.xml", package_xml(name, build_type, depend=depend,
                                               buildtool=buildtool))
    for rel, text in (files or {}).items():
        write(pkg / rel, text)
    return pkg


def snapshot(root: Path) -> dict[str, tuple[str, str, int]]:
    """Every file, link and directory under `root` with its content (or target) and mtime."""
    state: dict[str, tuple[str, str, int]] = {}
    if not root.exists():
        return state
    for dirpath, dirnames, filenames in os.walk(root):
        for name in sorted(dirnames + filenames):
            path = Path(dirpath, name)
            rel = str(path.relative_to(root))
            st = path.lstat()
            if path.is_symlink():
                state[rel] = ("link", os.readlink(path), st.st_mtime_ns)
            elif path.is_dir():
                state[rel] = ("dir", "", 0)
            else:
                state[rel] = ("file", hashlib.sha256(path.read_bytes()).hexdigest(),
                              st.st_mtime_ns)
    return state


def env_list(result: subprocess.CompletedProcess[str], var: str) -> list[str]:
    """Entries of a colon-separated variable printed by the script as `VAR=value` lines."""
    for line in result.stdout.splitlines():
        if line.startswith(f"{var}="):
            return [e for e in line[len(var) + 1:].split(":") if e]
    raise AssertionError(f"{var} not printed:\n{result.stdout}")


def print_vars(names: Iterable[str]) -> str:
    """Shell lines printing `VAR=value` for each variable (empty when unset, `set -u` safe)."""
    return "".join(f'echo "{n}=${{{n}:-}}"\n' for n in names)


PATH_VARS = ("PATH", "AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "COLCON_PREFIX_PATH",
             "PYTHONPATH", "LD_LIBRARY_PATH")
