"""Install layouts of `wsbuild build`: isolated, --merge-install, --symlink-install."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from conftest import write_package
from test_build_helpers import (
    build,
    env_list,
    output,
    print_vars,
    requires_ros,
    snapshot,
    sourced,
    write,
    write_ament_python,
    write_cmake,
    wsbuild,
)
from wsbuild.build_types.pybuild.paths import site_packages_relpath

SITE = site_packages_relpath()

LAY_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(lay_cmake NONE)
install(FILES data.txt DESTINATION share/${PROJECT_NAME})
"""


def _layout_ws(root: Path) -> Path:
    src = root / "src"
    write_package(src, "lay_py", "ament_python", ["lay_cmake"])
    write_cmake(src, "lay_cmake", LAY_CMAKE, files={"data.txt": "lay data\n"})
    return root


@pytest.mark.parametrize("layout", ["isolated", "merged"])
def test_layouts_put_packages_where_colcon_does_and_source_alike(tmp_path: Path,
                                                                 layout: str) -> None:
    ws = _layout_ws(tmp_path / "ws")
    merged = layout == "merged"
    build(ws, *(["--merge-install"] if merged else []))
    install = ws / "install"
    assert (install / ".colcon_install_layout").read_text().strip() == layout

    def prefix(name: str) -> Path:
        return install if merged else install / name

    assert (prefix("lay_py") / SITE / "lay_py" / "__init__.py").is_file()
    assert (prefix("lay_py") / "lib" / "lay_py" / "lay_py_main").is_file()
    assert (prefix("lay_cmake") / "share" / "lay_cmake" / "data.txt").read_text() == "lay data\n"
    assert (install / "lay_py").is_dir() != merged

    result = sourced(ws, print_vars(["AMENT_PREFIX_PATH"])
                     + '"$WSBUILD_TEST_PYTHON" -c "import lay_py; print(lay_py.__file__)"\n'
                     + '"$WSBUILD_TEST_PYTHON" -m wsbuild run lay_py lay_py_main\n',
                     cwd=tmp_path)
    lines = result.stdout.splitlines()
    assert Path(lines[1]) == prefix("lay_py") / SITE / "lay_py" / "__init__.py"
    assert lines[2] == "hello from lay_py"
    ament = env_list(result, "AMENT_PREFIX_PATH")
    for name in ("lay_py", "lay_cmake"):
        assert str(prefix(name)) in ament


@pytest.mark.parametrize("first", ["isolated", "merged"])
def test_switching_layout_without_cleaning_is_a_clear_error(tmp_path: Path, first: str) -> None:
    ws = _layout_ws(tmp_path / "ws")
    build(ws, *(["--merge-install"] if first == "merged" else []))
    before = snapshot(ws / "install")

    result = wsbuild("build", *([] if first == "merged" else ["--merge-install"]), cwd=ws)

    assert result.returncode == 2, output(result)
    error = [line for line in result.stderr.splitlines() if line.startswith("wsbuild: error:")]
    assert len(error) == 1, output(result)
    assert "--merge-install" in error[0] and first in error[0]
    assert "`wsbuild clean -y`" in error[0]  # the command that starts over
    assert "Starting" not in result.stdout
    assert snapshot(ws / "install") == before
    # which does what the error says: the other layout then builds
    assert wsbuild("clean", "-y", cwd=ws).returncode == 0
    build(ws, *([] if first == "merged" else ["--merge-install"]))


# ------------------------------------------------------------------------------ symlink install

SYM_MAIN = """\
def main():
    print('sym_py v1')
"""


@pytest.mark.parametrize("layout", ["isolated", "merged"])
def test_symlink_install_python_edits_take_effect_without_rebuilding(tmp_path: Path,
                                                                     layout: str) -> None:
    ws = tmp_path / "ws"
    src = ws / "src"
    pkg = write_ament_python(src, "sym_py", modules={"main.py": SYM_MAIN},
                             data={"launch/sym.launch.py": "# launch v1\n",
                                   "config/params.yaml": "rate: 1\n"},
                             scripts={"sym_hello": "sym_py.main:main"})
    merged = layout == "merged"
    build(ws, "--symlink-install", *(["--merge-install"] if merged else []))
    prefix = ws / "install" if merged else ws / "install" / "sym_py"
    share = prefix / "share" / "sym_py"
    run = '"$WSBUILD_TEST_PYTHON" -m wsbuild run sym_py sym_hello\n'
    assert sourced(ws, run).stdout.strip() == "sym_py v1"

    write(pkg / "sym_py" / "main.py", SYM_MAIN.replace("v1", "v2"))
    write(pkg / "launch" / "sym.launch.py", "# launch v2\n")
    write(pkg / "config" / "params.yaml", "rate: 2\n")

    assert sourced(ws, run).stdout.strip() == "sym_py v2"
    assert (share / "launch" / "sym.launch.py").read_text() == "# launch v2\n"
    assert (share / "config" / "params.yaml").read_text() == "rate: 2\n"


SYM_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(sym_cmake NONE)
find_package(ament_cmake REQUIRED)
install(FILES config/params.yaml DESTINATION share/${PROJECT_NAME}/config)
install(DIRECTORY launch DESTINATION share/${PROJECT_NAME})
install(PROGRAMS scripts/tool.sh DESTINATION lib/${PROJECT_NAME})
ament_package()
"""

SYM_FILES = {
    "config/params.yaml": "rate: 1\n",
    "launch/sym.launch.py": "# launch v1\n",
    "scripts/tool.sh": "#!/bin/sh\necho tool v1\n",
}

#: installed path (below the package's prefix) -> source path (below the package)
SYM_INSTALLED = {
    "share/sym_cmake/config/params.yaml": "config/params.yaml",
    "share/sym_cmake/launch/sym.launch.py": "launch/sym.launch.py",
    "lib/sym_cmake/tool.sh": "scripts/tool.sh",
}


def _sym_cmake_ws(root: Path) -> Path:
    pkg = write_cmake(root / "src", "sym_cmake", SYM_CMAKE, build_type="ament_cmake",
                      buildtool=["ament_cmake"], files=SYM_FILES)
    (pkg / "scripts" / "tool.sh").chmod(0o755)
    return root


def _assert_symlinked(prefix: Path, pkg: Path) -> None:
    for installed, source in SYM_INSTALLED.items():
        path = prefix / installed
        assert path.is_symlink(), f"{installed} is not a symlink"
        assert path.resolve() == (pkg / source).resolve()


@requires_ros
@pytest.mark.parametrize("layout", ["isolated", "merged"])
def test_symlink_install_ament_cmake_installs_symlinks_to_the_sources(tmp_path: Path,
                                                                      layout: str) -> None:
    ws = _sym_cmake_ws(tmp_path / "ws")
    pkg = ws / "src" / "sym_cmake"
    merged = layout == "merged"
    build(ws, "--symlink-install", *(["--merge-install"] if merged else []))
    prefix = ws / "install" if merged else ws / "install" / "sym_cmake"
    _assert_symlinked(prefix, pkg)

    write(pkg / "config" / "params.yaml", "rate: 2\n")
    assert (prefix / "share" / "sym_cmake" / "config" / "params.yaml").read_text() == "rate: 2\n"
    result = sourced(ws, '"$WSBUILD_TEST_PYTHON" -m wsbuild run sym_cmake tool.sh\n')
    assert result.stdout.strip() == "tool v1"


@requires_ros
@pytest.mark.parametrize("layout", [
    "isolated",
    "merged",
])
def test_turning_on_symlink_install_in_a_built_workspace(tmp_path: Path, layout: str) -> None:
    ws = _sym_cmake_ws(tmp_path / "ws")
    pkg = ws / "src" / "sym_cmake"
    merged = ["--merge-install"] if layout == "merged" else []
    prefix = ws / "install" if merged else ws / "install" / "sym_cmake"
    build(ws, *merged)
    assert not (prefix / "share" / "sym_cmake" / "config" / "params.yaml").is_symlink()

    build(ws, "--symlink-install", *merged)

    _assert_symlinked(prefix, pkg)
    assert (prefix / "share" / "sym_cmake" / "package.xml").is_file()


SWITCH_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(switcher NONE)
find_package(ament_cmake REQUIRED)
find_package(ament_cmake_python REQUIRED)
ament_python_install_package(${PROJECT_NAME})
install(DIRECTORY launch DESTINATION share/${PROJECT_NAME})
ament_package()
"""


@requires_ros
@pytest.mark.parametrize("layout", ["isolated", "merged"])
def test_switching_the_install_mode_and_deleting_a_file_need_no_clean(tmp_path: Path,
                                                                      layout: str) -> None:
    """An ament_cmake package installing a Python package (as a message package does):
    turning --symlink-install on after a normal build, off again, and deleting a source file
    under it each leave a correct install, with no clean by hand (colcon fails the first with
    "failed to create symbolic link ... Is a directory", colcon-core #692 and #633)."""
    ws = tmp_path / "ws"
    pkg = write_cmake(ws / "src", "switcher", SWITCH_CMAKE, build_type="ament_cmake",
                      buildtool=["ament_cmake", "ament_cmake_python"],
                      files={"switcher/__init__.py": "VALUE = 'v1'\n",
                             "launch/a.launch.py": "# a\n", "launch/b.launch.py": "# b\n"})
    merged = ["--merge-install"] if layout == "merged" else []
    prefix = ws / "install" if merged else ws / "install" / "switcher"
    share = prefix / "share" / "switcher" / "launch"
    module = prefix / "lib" / f"python{sys.version_info[0]}.{sys.version_info[1]}" / \
        "site-packages" / "switcher" / "__init__.py"
    build(ws, *merged)
    built = build(ws, "--symlink-install", *merged)
    # information, not a warning: the option was switched on purpose
    assert ("[switcher] built without --symlink-install, this build is with it: building it "
            "from scratch") in built.stdout.splitlines(), built.stdout
    assert "WARNING" not in built.stdout + built.stderr and "warnings" not in built.stdout
    assert (share / "a.launch.py").is_symlink() and module.is_symlink()
    write(pkg / "switcher" / "__init__.py", "VALUE = 'v2'\n")
    assert module.read_text() == "VALUE = 'v2'\n"

    (pkg / "launch" / "b.launch.py").unlink()  # deleted under symlink-install
    build(ws, "--symlink-install", *merged)
    assert sorted(p.name for p in share.iterdir()) == ["a.launch.py"]

    build(ws, *merged)  # and off again
    assert not (share / "a.launch.py").is_symlink() and not module.is_symlink()
    assert sorted(p.name for p in share.iterdir()) == ["a.launch.py"]
    write(pkg / "switcher" / "__init__.py", "VALUE = 'v3'\n")  # a copy now: no effect
    assert module.read_text() == "VALUE = 'v2'\n"
    if not merged:
        imported = '"$WSBUILD_TEST_PYTHON" -c "import switcher; print(switcher.VALUE)"\n'
        assert sourced(ws, imported).stdout.strip() == "v2"
