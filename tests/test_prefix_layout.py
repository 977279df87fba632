"""Install layout markers, the installed-package index and its dependency order."""

from __future__ import annotations

from pathlib import Path

import pytest

from wsbuild.errors import CycleError, WorkspaceError
from wsbuild.prefix.layout import (
    installed_order,
    mark_install_layout,
    order_packages,
    package_prefix,
    read_installed_packages,
    write_ignore_marker,
)


def index(prefix: Path, name: str, content: str) -> None:
    path = prefix / "share" / "colcon-core" / "packages" / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(content)


def test_read_isolated_install(tmp_path: Path) -> None:
    index(tmp_path / "b", "b", "rclpy:a")
    index(tmp_path / "a", "a", "")
    index(tmp_path / ".hidden", ".hidden", "")
    index(tmp_path / "c", "not_c", "")  # the file must be named like its prefix
    (tmp_path / "d" / "share").mkdir(parents=True)

    assert read_installed_packages(tmp_path, merged=False) == {"a": (), "b": ("a", "rclpy")}


def test_read_merged_install(tmp_path: Path) -> None:
    index(tmp_path, "b", "a")
    index(tmp_path, "a", "")
    index(tmp_path, ".hidden", "")

    assert read_installed_packages(tmp_path, merged=True) == {"a": (), "b": ("a",)}
    assert read_installed_packages(tmp_path / "missing", merged=True) == {}
    assert read_installed_packages(tmp_path / "missing", merged=False) == {}


def test_order_is_topological_with_ties_by_name() -> None:
    packages = {
        "zed": (),
        "beta": ("zed", "external"),
        "alpha": ("zed",),
        "gamma": ("alpha", "beta", "gamma"),
        "aaa": (),
    }

    assert order_packages(packages) == ["aaa", "zed", "alpha", "beta", "gamma"]


def test_installed_order(tmp_path: Path) -> None:
    index(tmp_path / "b", "b", "a")
    index(tmp_path / "a", "a", "")
    index(tmp_path / "aa", "aa", "b")

    assert installed_order(tmp_path, merged=False) == ["a", "b", "aa"]


def test_cycle_lists_the_remaining_edges() -> None:
    with pytest.raises(CycleError, match="a -> b; b -> a"):
        order_packages({"a": ("b",), "b": ("a",), "c": ()})


def test_layout_marker(tmp_path: Path) -> None:
    assert mark_install_layout(tmp_path, merged=False) == tmp_path / ".colcon_install_layout"
    assert mark_install_layout(tmp_path, merged=False) is None
    assert (tmp_path / ".colcon_install_layout").read_text() == "isolated\n"
    with pytest.raises(WorkspaceError, match="add the '--merge-install' option|remove"):
        mark_install_layout(tmp_path, merged=True)


def test_ignore_marker_is_created_once(tmp_path: Path) -> None:
    assert write_ignore_marker(tmp_path) == tmp_path / "COLCON_IGNORE"
    (tmp_path / "COLCON_IGNORE").write_text("kept")

    assert write_ignore_marker(tmp_path) is None
    assert (tmp_path / "COLCON_IGNORE").read_text() == "kept"


def test_package_prefix(tmp_path: Path) -> None:
    assert package_prefix(tmp_path, "foo", merged=False) == tmp_path / "foo"
    assert package_prefix(tmp_path, "foo", merged=True) == tmp_path
