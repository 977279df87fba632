"""environment_for: the build environment from dependency prefixes, computed in-process."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from test_prefix_trees import install_workspace, source_and_dump

from wsbuild.errors import WsbuildError
from wsbuild.prefix import environment_for

PACKAGES = {
    "zed": ("cmake", ()),
    "alpha": ("ament_python", ("zed",)),
    "mid": ("ament_cmake", ("alpha",)),
}
LISTS = ("PATH", "AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "LD_LIBRARY_PATH", "PYTHONPATH")


@pytest.fixture
def install(tmp_path: Path) -> Path:
    base = tmp_path / "my ws" / "install"
    install_workspace(base, PACKAGES)
    return base


def dependencies(install: Path) -> list[tuple[Path, str]]:
    return [(install / name, name) for name in ("zed", "alpha", "mid")]


def test_same_as_sourcing_each_package_sh_in_bash(install: Path) -> None:
    base = {
        "PATH": f"/usr/bin::{install}/zed/bin:/bin",
        "CMAKE_PREFIX_PATH": f"/opt/ros/jazzy:{install}/mid",
        "PYTHONPATH": "",
        "HOME": "/root",
    }
    # what colcon's command_prefix.sh does: source each dependency's package.sh in order
    command = "\n".join(f". '{prefix}/share/{name}/package.sh'" for prefix, name in dependencies(install))
    sourced, _ = source_and_dump("bash", "", env=dict(base), command=command)

    computed = environment_for(dependencies(install), base)

    for name in LISTS:
        assert computed.get(name) == sourced.get(name), name
    assert computed["AMENT_PREFIX_PATH"] == f"{install}/mid:{install}/alpha"
    assert computed["PATH"] == f"{install}/zed/bin:/usr/bin:/bin"
    assert base["PYTHONPATH"] == ""  # the base mapping is left alone


def test_set_append_and_set_if_unset(tmp_path: Path) -> None:
    prefix = tmp_path / "pkg"
    share = prefix / "share" / "pkg"
    share.mkdir(parents=True)
    (prefix / "data").mkdir()
    (share / "package.dsv").write_text(
        "set;PKG_DATA;data\n"
        "set;PKG_NAME;not-a-path\n"
        "set-if-unset;KEEP;new\n"
        "set-if-unset;FILL;new\n"
        "append-non-duplicate;LIST;/b;/a\n"
        "prepend-non-duplicate-if-exists;PATH;bin;data\n"
    )

    env = environment_for([(prefix, "pkg")], {"KEEP": "old", "LIST": "/a", "PATH": "/bin"})

    assert env["PKG_DATA"] == f"{prefix}/data"
    assert env["PKG_NAME"] == "not-a-path"
    assert env["KEEP"] == "old"
    assert env["FILL"] == "new"
    assert env["LIST"] == "/a:/b"
    assert env["PATH"] == f"{prefix}/data:/bin"


def test_script_without_dsv_is_sourced_by_sh(install: Path) -> None:
    share = install / "alpha" / "share" / "alpha"
    (share / "hook" / "custom.sh").write_text(
        'export CUSTOM="$COLCON_CURRENT_PREFIX"\n'
        '_colcon_prepend_unique_value PATH "$COLCON_CURRENT_PREFIX/tools"\n'
        "echo noise\n"
    )
    with (share / "package.dsv").open("a") as dsv:
        dsv.write("source;share/alpha/hook/custom.sh\n")

    env = environment_for(dependencies(install), {"PATH": "/bin"})

    assert env["CUSTOM"] == str(install / "alpha")
    assert env["PATH"].split(":") == [f"{install}/alpha/tools", f"{install}/zed/bin", "/bin"]
    assert "COLCON_CURRENT_PREFIX" not in env
    assert env["AMENT_PREFIX_PATH"] == f"{install}/mid:{install}/alpha"


def test_changed_package_dsv_is_picked_up(install: Path) -> None:
    before = environment_for(dependencies(install), {})
    dsv = install / "zed" / "share" / "zed" / "package.dsv"
    dsv.write_text(dsv.read_text() + "set;ZED_EXTRA;1\n")
    os.utime(dsv, ns=(dsv.stat().st_atime_ns, dsv.stat().st_mtime_ns + 1_000_000))

    after = environment_for(dependencies(install), {})

    assert "ZED_EXTRA" not in before
    assert after["ZED_EXTRA"] == "1"


def test_missing_package_dsv_adds_nothing(tmp_path: Path) -> None:
    assert environment_for([(tmp_path / "nothing", "nothing")], {"A": "1"}) == {"A": "1"}


def test_broken_dsv_names_file_and_line(tmp_path: Path) -> None:
    share = tmp_path / "pkg" / "share" / "pkg"
    share.mkdir(parents=True)
    (share / "package.dsv").write_text("# comment\nprepend-non-duplicate;PATH;bin\nbogus line\n")

    with pytest.raises(WsbuildError) as info:
        environment_for([(tmp_path / "pkg", "pkg")], {})

    assert info.value.path == share / "package.dsv"
    assert info.value.line == 3
