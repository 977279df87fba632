"""colcon interop both ways: a colcon overlay on a wsbuild underlay and a wsbuild overlay on a
colcon underlay; each builds, is sourced alone and finds the other's packages.

colcon comes from PyPI into a virtualenv of the session (the `colcon` fixture of conftest.py).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from test_build_helpers import (
    REQUIRES_ROS,
    clean_env,
    env_list,
    output,
    print_vars,
    ros_underlay,
    sh_quote,
    shell,
    sourced,
    write_ament_python,
    write_cmake,
    wsbuild,
)
from wsbuild.underlay.environment import build_environment

# `colcon` (tests/conftest.py): the oracle's executable, in a virtualenv made once per run
pytestmark = [*REQUIRES_ROS, pytest.mark.slow]


def colcon_build(colcon: Path, ws: Path, *, source: Path | None, home: Path,
                 env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """`colcon build` in `ws`, after sourcing `source` (a setup.bash) if given."""
    prefix = f". {sh_quote(str(source))}\n" if source else ""
    full = dict(env or clean_env())
    full["COLCON_HOME"] = str(home)  # no user defaults or mixins
    result = shell(f"{prefix}{sh_quote(str(colcon))} build --event-handlers console_cohesion+\n",
                   cwd=ws, env=full, strict=source is None)
    assert result.returncode == 0, output(result)
    return result


AMENT_VALUE_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
find_package(ament_cmake REQUIRED)
install(FILES config/params.yaml DESTINATION share/${{PROJECT_NAME}}/config)
ament_package(CONFIG_EXTRAS {name}-extras.cmake)
"""

AMENT_USER_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
find_package(ament_cmake REQUIRED)
find_package({dep} REQUIRED)
file(WRITE ${{CMAKE_BINARY_DIR}}/value.txt "${{{dep}_VALUE}}\\n")
install(FILES ${{CMAKE_BINARY_DIR}}/value.txt DESTINATION share/${{PROJECT_NAME}})
ament_package()
"""

USER_MAIN = """\
from ament_index_python.packages import get_package_share_directory
import {dep_py}


def main():
    share = get_package_share_directory({dep_cmake!r})
    with open(share + '/config/params.yaml') as handle:
        params = handle.read().strip()
    print(f'{name} sees {{{dep_py}.VALUE}} and {{params}}')
"""


def write_provider(ws: Path, tag: str) -> None:
    """`<tag>_py` (a Python library) and `<tag>_ament` (ament_cmake, exports a variable)."""
    write_ament_python(ws / "src", f"{tag}_py", modules={"__init__.py": f"VALUE = '{tag} py'\n"})
    name = f"{tag}_ament"
    write_cmake(ws / "src", name, AMENT_VALUE_CMAKE.format(name=name), build_type="ament_cmake",
                buildtool=["ament_cmake"],
                files={"config/params.yaml": f"source: {tag}\n",
                       f"{name}-extras.cmake": f'set({name}_VALUE "{tag} cmake")\n'})


def write_user(ws: Path, tag: str, dep: str) -> None:
    """`<tag>_py` (console script using `<dep>_py` and `<dep>_ament`'s share directory) and
    `<tag>_ament` (ament_cmake, find_package(<dep>_ament))."""
    py, cmake = f"{tag}_py", f"{tag}_ament"
    write_ament_python(ws / "src", py,
                       modules={"main.py": USER_MAIN.format(name=py, dep_py=f"{dep}_py",
                                                            dep_cmake=f"{dep}_ament")},
                       scripts={f"{tag}_main": f"{py}.main:main"},
                       depend=[f"{dep}_py"], exec_depend=[f"{dep}_ament", "ament_index_python"])
    write_cmake(ws / "src", cmake, AMENT_USER_CMAKE.format(name=cmake, dep=f"{dep}_ament"),
                build_type="ament_cmake", buildtool=["ament_cmake"], depend=[f"{dep}_ament"])


CHECK = """\
{python} -c 'from ament_index_python.packages import get_package_share_directory as g; \
print(g("{a}")); print(g("{b}"))'
"$WSBUILD_TEST_PYTHON" -c 'import {a_py}, {b_py}; print({a_py}.__file__); print({b_py}.__file__)'
"""


def test_colcon_overlay_on_a_wsbuild_underlay(colcon: Path, tmp_path: Path) -> None:
    under, over = tmp_path / "wsbuild_under", tmp_path / "colcon over"
    write_provider(under, "wa")
    result = wsbuild("build", cwd=under)
    assert result.returncode == 0, output(result)
    write_user(over, "cb", "wa")
    colcon_build(colcon, over, source=under / "install" / "setup.bash", home=tmp_path / "home")

    value = over / "install" / "cb_ament" / "share" / "cb_ament" / "value.txt"
    assert value.read_text() == "wa cmake\n"
    # a fresh shell sources only the colcon overlay: it chains the wsbuild underlay (colcon
    # sources an underlay's local_setup only, so the ROS venv, which wsbuild's setup.bash
    # chains, is not applied: the venv's Python is named explicitly)
    script = (print_vars(["AMENT_PREFIX_PATH"])
              + CHECK.format(a="wa_ament", b="cb_ament", a_py="wa_py", b_py="cb_py",
                             python='"$WSBUILD_TEST_PYTHON"')
              + sh_quote(str(over / "install" / "cb_py" / "lib" / "cb_py" / "cb_main")) + "\n")
    result = sourced(over, script, cwd=Path("/"), strict=False)  # colcon's scripts need it
    lines = result.stdout.splitlines()
    assert Path(lines[1]) == under / "install" / "wa_ament" / "share" / "wa_ament"
    assert Path(lines[2]) == over / "install" / "cb_ament" / "share" / "cb_ament"
    assert lines[3].startswith(str(under / "install" / "wa_py"))
    assert lines[4].startswith(str(over / "install" / "cb_py"))
    assert lines[-1] == "cb_py sees wa py and source: wa"
    ament = env_list(result, "AMENT_PREFIX_PATH")
    assert ament.index(str(over / "install" / "cb_py")) < \
        ament.index(str(under / "install" / "wa_py"))


def test_wsbuild_overlay_on_a_colcon_underlay(colcon: Path, tmp_path: Path) -> None:
    under, over = tmp_path / "colcon under", tmp_path / "wsbuild_over"
    write_provider(under, "ca")
    ros = ros_underlay()
    assert ros is not None
    # colcon builds against the ROS venv as a sourced ROS would be: its variables applied
    ros_env = clean_env()
    ros_env.update(build_environment(ros, ros_env))
    colcon_build(colcon, under, source=None, home=tmp_path / "home", env=ros_env)
    write_user(over, "wd", "ca")

    # a fresh shell: source the colcon underlay, build the overlay with wsbuild
    sourced(under, '"$WSBUILD_TEST_PYTHON" -m wsbuild build\n', cwd=over, env=ros_env,
            strict=False)

    value = over / "install" / "wd_ament" / "share" / "wd_ament" / "value.txt"
    assert value.read_text() == "ca cmake\n"
    # sourcing only the wsbuild overlay brings the colcon underlay and the ROS venv
    script = (print_vars(["AMENT_PREFIX_PATH"])
              + CHECK.format(a="ca_ament", b="wd_ament", a_py="ca_py", b_py="wd_py",
                             python="python3")
              + '"$WSBUILD_TEST_PYTHON" -m wsbuild run wd_py wd_main\n')
    # not under `set -u`: the chained colcon local_setup.bash does not support it
    result = sourced(over, script, cwd=Path("/"), strict=False)
    lines = result.stdout.splitlines()
    assert Path(lines[1]) == under / "install" / "ca_ament" / "share" / "ca_ament"
    assert Path(lines[2]) == over / "install" / "wd_ament" / "share" / "wd_ament"
    assert lines[3].startswith(str(under / "install" / "ca_py"))
    assert lines[4].startswith(str(over / "install" / "wd_py"))
    assert lines[-1] == "wd_py sees ca py and source: ca"
    ament = env_list(result, "AMENT_PREFIX_PATH")
    assert ament.index(str(over / "install" / "wd_py")) < \
        ament.index(str(under / "install" / "ca_py"))
