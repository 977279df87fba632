"""Package discovery: what is found, what is skipped, and how packages are identified."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from conftest import run_wsbuild, write_package
from wsbuild.workspace.discover import discover_packages, find_package_dirs
from wsbuild.errors import ManifestError, WorkspaceError
from wsbuild.build_types import KnownBuildTypes
from wsbuild.workspace.root import Workspace, find_workspace_root


def _names(root: Path) -> list[str]:
    found = discover_packages([], base_paths=[root], environ={}, known_build_types=KnownBuildTypes())
    return sorted(found.packages)


def test_finds_nested_packages_and_stops_inside_a_package(tmp_path: Path) -> None:
    write_package(tmp_path, "outer", "ament_cmake")
    write_package(tmp_path / "outer", "inner", "ament_cmake")  # inside a package: not a package
    write_package(tmp_path, "deep", "ament_python", subdir="a/b/c")
    assert _names(tmp_path) == ["deep", "outer"]


@pytest.mark.parametrize("marker", ["COLCON_IGNORE", "AMENT_IGNORE", "CATKIN_IGNORE"])
def test_ignore_markers(tmp_path: Path, marker: str) -> None:
    write_package(tmp_path, "kept", "cmake")
    ignored = write_package(tmp_path, "gone", "cmake", subdir="group")
    (ignored.parent / marker).touch()
    assert _names(tmp_path) == ["kept"]


def test_skips_hidden_venvs_and_conda(tmp_path: Path) -> None:
    write_package(tmp_path, "kept", "cmake")
    write_package(tmp_path, "hidden", "cmake", subdir=".git")
    venv = tmp_path / "venv"
    write_package(venv, "in_venv", "cmake", subdir="lib")
    (venv / "pyvenv.cfg").write_text("home = /usr\n")
    conda = tmp_path / "conda"
    write_package(conda, "in_conda", "cmake")
    (conda / "conda-meta").mkdir()
    assert _names(tmp_path) == ["kept"]


def test_symlink_loops_terminate_and_symlinked_packages_count_once(tmp_path: Path) -> None:
    write_package(tmp_path / "real", "linked", "cmake")
    (tmp_path / "alias").symlink_to(tmp_path / "real")
    (tmp_path / "real" / "loop").symlink_to(tmp_path)
    assert _names(tmp_path) == ["linked"]


def test_workspace_build_install_log_are_skipped(tmp_path: Path) -> None:
    write_package(tmp_path, "kept", "cmake")
    write_package(tmp_path / "install", "installed_copy", "cmake")
    dirs = find_package_dirs([tmp_path], skip=[tmp_path / "install"])
    assert [d.name for d in dirs] == ["kept"]


def test_packages_without_manifest(tmp_path: Path) -> None:
    plain = tmp_path / "plain_cmake"
    plain.mkdir()
    (plain / "CMakeLists.txt").write_text("cmake_minimum_required(VERSION 3.14)\n"
                                          "project(plain_cmake)\nfind_package(other)\n")
    py = tmp_path / "py"
    py.mkdir()
    (py / "pyproject.toml").write_text('[project]\nname = "my-lib"\nversion = "1.0"\n')
    tool_only = tmp_path / "tooling"
    tool_only.mkdir()
    (tool_only / "pyproject.toml").write_text("[tool.ruff]\nline-length = 99\n")
    found = discover_packages([], base_paths=[tmp_path], environ={}, known_build_types=KnownBuildTypes()).packages
    assert sorted(found) == ["my-lib", "plain_cmake"]
    assert found["plain_cmake"].build_type == "cmake"
    assert found["my-lib"].build_type == "python"
    assert "other" in {d.name for d in found["plain_cmake"].dependencies}


def test_duplicate_names_name_both_paths(tmp_path: Path) -> None:
    write_package(tmp_path, "twin", "cmake", subdir="one")
    write_package(tmp_path, "twin", "cmake", subdir="two")
    with pytest.raises(WorkspaceError) as info:
        discover_packages([], base_paths=[tmp_path], environ={}, known_build_types=KnownBuildTypes())
    text = str(info.value)
    assert str(tmp_path / "one" / "twin") in text and str(tmp_path / "two" / "twin") in text
    assert "\n" not in text


def test_cmake_without_project_is_an_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "CMakeLists.txt").write_text("message(hi)\n")
    with pytest.raises(ManifestError, match="project"):
        discover_packages([], base_paths=[tmp_path], environ={}, known_build_types=KnownBuildTypes())


def test_workspace_root_found_from_src_and_from_inside_a_package(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    pkg = write_package(ws / "src", "cpp_pkg", "ament_cmake")
    (pkg / "src").mkdir()  # a package's own src/ must not make it a workspace
    (pkg / "src" / "deeper").mkdir()
    assert find_workspace_root(ws) == ws
    assert find_workspace_root(ws / "src") == ws
    assert find_workspace_root(pkg) == ws
    assert find_workspace_root(pkg / "src" / "deeper") == ws


def test_workspace_root_without_src_is_the_start(tmp_path: Path) -> None:
    assert find_workspace_root(tmp_path) == tmp_path
    assert Workspace.at(tmp_path).default_base_paths() == [tmp_path]
    os.makedirs(tmp_path / "src")
    assert Workspace.at(tmp_path).default_base_paths() == [tmp_path / "src"]


def test_a_build_inside_a_package_says_which_workspace_it_builds_and_why(tmp_path: Path) -> None:
    """`wsbuild build` in src/pkg builds the workspace above it: it says so, and why that one."""
    ws = tmp_path / "ws"
    pkg = write_package(ws / "src", "here", "cmake")
    (pkg / "CMakeLists.txt").write_text("cmake_minimum_required(VERSION 3.14)\nproject(here NONE)\n")
    inside = run_wsbuild("build", cwd=pkg)
    assert inside.returncode == 0, inside.stdout + inside.stderr
    assert (f"wsbuild: note: workspace {ws}: the nearest directory above {pkg} holding src/ "
            "(-C DIR names another)") in inside.stderr.splitlines()
    assert (ws / "install" / "here").is_dir()
    at_root = run_wsbuild("build", cwd=ws)
    assert at_root.returncode == 0 and "note: workspace" not in at_root.stderr
    again = run_wsbuild("test", cwd=pkg / "..")
    assert "holding build/ of an earlier build" in again.stderr, again.stderr
