"""A wsbuild workspace built on top of another (overlay on underlay), then sourced alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from test_build_helpers import (
    build,
    env_list,
    output,
    print_vars,
    sh_quote,
    shell,
    sourced,
    write_ament_python,
    write_cmake,
    wsbuild,
)

BASE_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(base_cmake NONE)
file(WRITE ${CMAKE_BINARY_DIR}/base_cmakeConfig.cmake "set(BASE_CMAKE_VALUE \\"from base\\")\\n")
install(FILES ${CMAKE_BINARY_DIR}/base_cmakeConfig.cmake DESTINATION share/${PROJECT_NAME}/cmake)
"""

TOP_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(top_cmake NONE)
find_package(base_cmake REQUIRED)
file(WRITE ${CMAKE_BINARY_DIR}/value.txt "${BASE_CMAKE_VALUE}\\n")
install(FILES ${CMAKE_BINARY_DIR}/value.txt DESTINATION share/${PROJECT_NAME})
"""

TOP_MAIN = """\
import base_py
import shadow_py


def main():
    print(f'top sees {base_py.VALUE} and shadow {shadow_py.VALUE}')
"""


@pytest.fixture(scope="module")
def overlay(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(underlay, overlay): the overlay built in a shell that sourced the underlay."""
    root = tmp_path_factory.mktemp("overlay")
    under, over = root / "underlay ws", root / "overlay_ws"
    write_ament_python(under / "src", "base_py", modules={"__init__.py": "VALUE = 'base v1'\n"})
    write_ament_python(under / "src", "shadow_py", modules={"__init__.py": "VALUE = 'under'\n"})
    write_cmake(under / "src", "base_cmake", BASE_CMAKE)
    build(under)
    write_ament_python(over / "src", "top_py", modules={"main.py": TOP_MAIN},
                       scripts={"top_main": "top_py.main:main"}, depend=["base_py", "shadow_py"])
    write_ament_python(over / "src", "shadow_py", modules={"__init__.py": "VALUE = 'over'\n"})
    write_cmake(over / "src", "top_cmake", TOP_CMAKE, depend=["base_cmake"])
    sourced(under, '"$WSBUILD_TEST_PYTHON" -m wsbuild build\n', cwd=over)
    return under, over


def test_overlay_without_its_underlay_warns_and_strict_refuses(
        overlay: tuple[Path, Path]) -> None:
    """Forgetting to source the underlay: --dry-run lists what is missing (touching nothing),
    --strict-dependencies refuses; neither rewrites the overlay's install."""
    _, over = overlay
    setup = (over / "install" / "setup.bash").read_text()
    planned = wsbuild("build", "--packages-select", "top_py", "top_cmake", "--dry-run", cwd=over)
    assert planned.returncode == 0, output(planned)
    text = planned.stdout + planned.stderr
    assert "base_py" in text and "base_cmake" in text
    result = wsbuild("build", "--packages-select", "top_py", "top_cmake",
                     "--strict-dependencies", cwd=over)
    assert result.returncode == 2, output(result)
    assert "base_py (needed by top_py)" in result.stderr
    assert "base_cmake (needed by top_cmake)" in result.stderr
    assert (over / "install" / "setup.bash").read_text() == setup


def test_overlay_builds_against_the_underlay_packages(overlay: tuple[Path, Path]) -> None:
    _, over = overlay
    value = over / "install" / "top_cmake" / "share" / "top_cmake" / "value.txt"
    assert value.read_text() == "from base\n"


def test_overlay_setup_re_sources_its_underlay(overlay: tuple[Path, Path]) -> None:
    under, over = overlay
    result = sourced(over, print_vars(["AMENT_PREFIX_PATH"])
                     + '"$WSBUILD_TEST_PYTHON" -m wsbuild run top_py top_main\n', cwd=Path("/"))
    assert "top sees base v1 and shadow over" in result.stdout
    ament = env_list(result, "AMENT_PREFIX_PATH")
    # the overlay comes first: its packages shadow the underlay's
    for name in ("top_py", "shadow_py", "base_py"):
        assert any(entry.startswith(str(over) if name != "base_py" else str(under))
                   for entry in ament), (name, ament)
    assert ament.index(str(over / "install" / "shadow_py")) < \
        ament.index(str(under / "install" / "shadow_py"))


def test_overlay_local_setup_does_not_bring_the_underlay(overlay: tuple[Path, Path]) -> None:
    under, over = overlay
    local = sh_quote(str(over / "install" / "local_setup.bash"))
    result = shell(f". {local}\n" + print_vars(["AMENT_PREFIX_PATH"]), cwd=over)
    assert result.returncode == 0, output(result)
    assert str(under) not in result.stdout
    assert str(over / "install" / "top_py") in env_list(result, "AMENT_PREFIX_PATH")
