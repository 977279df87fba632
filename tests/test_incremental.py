"""Incremental builds: exactly the packages whose inputs changed rebuild, and their dependents."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from conftest import run_wsbuild

# the tests share one workspace and edit it in turn: keep them on one xdist worker, in order
pytestmark = pytest.mark.xdist_group("incremental")


def built(output: str) -> list[str]:
    """The packages built or restored from the build cache (both install anew)."""
    return sorted(re.findall(r"^(?:Starting >>>|Restored <<<) (\S+)", output, re.MULTILINE))


@pytest.fixture(scope="module")
def ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """lib (cmake, installs a header) <- app (cmake) ; nodes (ament_python, launch file) ; other."""
    from conftest import write_package

    root = tmp_path_factory.mktemp("incr") / "ws"
    src = root / "src"
    lib = write_package(src, "lib", "cmake")
    (lib / "include").mkdir()
    (lib / "include" / "lib.h").write_text("#define LIB_VALUE 1\n")
    (lib / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.14)\nproject(lib NONE)\n"
        "install(DIRECTORY include/ DESTINATION include)\n"
        "install(FILES package.xml DESTINATION share/lib)\n")
    write_package(src, "app", "cmake", ["lib"])
    nodes = write_package(src, "nodes", "ament_python")
    (nodes / "launch").mkdir()
    (nodes / "launch" / "demo.launch.py").write_text("# launch v1\n")
    setup = nodes / "setup.py"
    setup.write_text(setup.read_text().replace(
        "('share/' + package_name, ['package.xml']),",
        "('share/' + package_name, ['package.xml']),\n"
        "        ('share/' + package_name + '/launch', ['launch/demo.launch.py']),"))
    write_package(src, "other", "cmake")
    first = run_wsbuild("build", cwd=root)
    assert first.returncode == 0, first.stdout + first.stderr
    assert built(first.stdout) == ["app", "lib", "nodes", "other"]
    return root


def rebuild(ws: Path, *args: str) -> list[str]:
    result = run_wsbuild("build", *args, cwd=ws)
    assert result.returncode == 0, result.stdout + result.stderr
    return built(result.stdout)


def test_noop_rebuild_builds_nothing(ws: Path) -> None:
    result = run_wsbuild("build", cwd=ws)
    assert built(result.stdout) == []
    assert "4 packages up to date" in result.stdout
    reasons = (ws / "log" / "latest_build" / "up_to_date.log").read_text()
    assert "app: up to date, nothing changed" in reasons


def test_touch_without_change_is_not_a_rebuild(ws: Path) -> None:
    (ws / "src" / "other" / "package.xml").touch()
    assert rebuild(ws) == []


def test_python_edit_rebuilds_only_that_package(ws: Path) -> None:
    main = ws / "src" / "nodes" / "nodes" / "main.py"
    main.write_text(main.read_text() + "# edited\n")
    assert rebuild(ws) == ["nodes"]
    why = (ws / "log" / "latest_build" / "nodes" / "command.log").read_text()
    assert why.startswith("Rebuilding: source changed: nodes/main.py")
    installed = ws / "install" / "nodes" / "lib" / "python3.11" / "site-packages" / "nodes" / "main.py"
    assert "# edited" in installed.read_text()


def test_launch_file_edit(ws: Path) -> None:
    (ws / "src" / "nodes" / "launch" / "demo.launch.py").write_text("# launch v2\n")
    assert rebuild(ws) == ["nodes"]
    assert (ws / "install" / "nodes" / "share" / "nodes" / "launch" / "demo.launch.py"
            ).read_text() == "# launch v2\n"


def test_a_dependency_header_its_dependent_never_reads_rebuilds_the_dependency_only(
        ws: Path) -> None:
    """app (`project(app NONE)`) compiles nothing: lib's header is not among what its build
    read, so lib's rebuild stops at lib (early cutoff; tests/test_early_cutoff.py has
    dependents that do read it)."""
    (ws / "src" / "lib" / "include" / "lib.h").write_text("#define LIB_VALUE 2\n")
    assert rebuild(ws) == ["lib"]


def test_package_xml_edit(ws: Path) -> None:
    xml = ws / "src" / "other" / "package.xml"
    xml.write_text(xml.read_text().replace("Test package other", "Changed description"))
    assert rebuild(ws) == ["other"]


def test_cmake_args_change_rebuilds_cmake_packages(ws: Path) -> None:
    # CMake arguments do not reach the ament_python package
    assert rebuild(ws, "--cmake-args", "-DSOME_OPTION=1") == ["app", "lib", "other"]
    assert rebuild(ws, "--cmake-args", "-DSOME_OPTION=1") == []
    assert rebuild(ws) == ["app", "lib", "other"]  # back to the defaults for the next tests


def test_deleted_installed_file_triggers_rebuild(ws: Path) -> None:
    rebuild(ws)
    (ws / "install" / "lib" / "include" / "lib.h").unlink()
    # the reinstalled lib is the same build, so app does not need rebuilding
    assert rebuild(ws) == ["lib"]
    assert (ws / "install" / "lib" / "include" / "lib.h").exists()


def test_force_and_selection(ws: Path) -> None:
    assert rebuild(ws, "--force", "--packages-select", "other") == ["other"]
    main = ws / "src" / "nodes" / "nodes" / "main.py"
    main.write_text(main.read_text() + "# again\n")
    assert rebuild(ws, "--packages-select", "other") == []  # the selection is respected
    assert rebuild(ws) == ["nodes"]
