"""The dependency check: each source that resolves a dependency, and what a build does with the
ones nothing resolves (a warning block before the build, the failure report of a package that
declared them, a refusal only with --strict-dependencies)."""

from __future__ import annotations

import json
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from test_build_helpers import output, package_xml, write, write_cmake, wsbuild
from wsbuild.underlay.wheels import install_hint
from wsbuild.workspace.model import Resolution
from wsbuild.workspace.resolve import Resolver

# ------------------------------------------------------------------------- the sources


def _resolver(tmp_path: Path, **environ: str) -> Resolver:
    return Resolver.from_environment({"PATH": str(tmp_path / "nothing"), **environ},
                                     detailed=True)


def test_the_ament_index_of_a_prefix(tmp_path: Path) -> None:
    index = tmp_path / "under" / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / "nav_msgs").write_text("")
    resolver = _resolver(tmp_path, AMENT_PREFIX_PATH=str(tmp_path / "under"))
    assert resolver.resolve("nav_msgs") == (Resolution.AMENT_INDEX, str(tmp_path / "under"))


def test_a_cmake_config_in_cmake_prefix_path(tmp_path: Path) -> None:
    upper = tmp_path / "p" / "lib" / "cmake" / "Eigen3" / "Eigen3Config.cmake"
    lower = tmp_path / "p" / "share" / "yaml_cpp_vendor" / "cmake" / "yaml_cpp_vendor-config.cmake"
    for path in (upper, lower):
        write(path, "")
    resolver = _resolver(tmp_path, CMAKE_PREFIX_PATH=str(tmp_path / "p"))
    assert resolver.resolve("Eigen3") == (Resolution.CMAKE, str(upper))
    assert resolver.resolve("yaml_cpp_vendor") == (Resolution.CMAKE, str(lower))


def _distribution(site: Path, name: str, version: str) -> None:
    write(site / f"{name.replace('-', '_')}-{version}.dist-info" / "METADATA",
          f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")


def test_the_build_check_names_distributions_by_their_directories(tmp_path: Path) -> None:
    """The build's check reads no metadata: the dist-info directory's name is the answer."""
    site = tmp_path / "site"
    _distribution(site, "Xacro-Tools", "2.0")
    fast = Resolver.from_environment({"PATH": "", "PYTHONPATH": str(site)})
    assert fast.resolve("xacro_tools") == (Resolution.PYTHON, "Xacro_Tools 2.0")
    assert fast.resolve("python3-xacro-tools") == (Resolution.PYTHON, "Xacro_Tools 2.0")
    assert fast.resolve("python3-not-there")[0] is not Resolution.PYTHON


def test_an_installed_python_distribution_with_the_python3_convention(tmp_path: Path) -> None:
    site = tmp_path / "site"
    _distribution(site, "Xacro-Tools", "2.0")
    _distribution(site, "PyYAML", "6.0")
    _distribution(site, "transforms3d", "0.4")
    resolver = _resolver(tmp_path, PYTHONPATH=str(site))
    assert resolver.resolve("xacro_tools") == (Resolution.PYTHON, "Xacro-Tools 2.0")
    assert resolver.resolve("python3-transforms3d") == (Resolution.PYTHON, "transforms3d 0.4")
    # rosdep keys whose distribution has another name
    assert resolver.resolve("python3-yaml") == (Resolution.PYTHON, "PyYAML 6.0")


def test_the_venv_underlay_distributions(tmp_path: Path) -> None:
    venv = tmp_path / "venv"
    _distribution(venv / "lib" / "python3.99" / "site-packages", "xacro", "2.1.1")
    resolver = Resolver.from_environment({"PATH": ""}, [venv])
    assert resolver.resolve("xacro") == (Resolution.PYTHON, "xacro 2.1.1")


def test_an_executable_on_path(tmp_path: Path) -> None:
    tool = write(tmp_path / "bin" / "protoc", "#!/bin/sh\n")
    tool.chmod(tool.stat().st_mode | stat.S_IXUSR)
    resolver = Resolver.from_environment({"PATH": str(tmp_path / "bin")})
    assert resolver.resolve("protoc") == (Resolution.EXECUTABLE, str(tool))


def test_a_pkg_config_module(tmp_path: Path) -> None:
    pkgconfig = shutil.which("pkg-config")
    assert pkgconfig is not None, "scripts/setup.sh's compilers bring pkg-config"
    write(tmp_path / "pc" / "libfrob.pc", "Name: frob\nDescription: d\nVersion: 1.2.3\n")
    environ = {"PATH": str(Path(pkgconfig).parent), "PKG_CONFIG_PATH": str(tmp_path / "pc")}
    resolver = Resolver.from_environment(environ, detailed=True)
    assert resolver.resolve("libfrob") == (Resolution.PKG_CONFIG, "libfrob 1.2.3")
    # the build's check asks pkg-config once for every module it knows
    fast = Resolver.from_environment(environ)
    assert fast.resolve("libfrob") == (Resolution.PKG_CONFIG, "libfrob")
    assert fast.resolve("libnot_there")[0] is Resolution.UNRESOLVED


def test_unresolved_python_and_ros_names_and_unchecked_system_keys(tmp_path: Path) -> None:
    resolver = _resolver(tmp_path)
    assert resolver.resolve("no_such_ros_pkg") == (Resolution.UNRESOLVED, "")
    assert resolver.resolve("python3-no-such-thing")[0] is Resolution.UNRESOLVED
    assert resolver.resolve("libfoo-dev") == (Resolution.SYSTEM, "")


def test_the_fix_a_warning_suggests() -> None:
    assert install_hint("geometry_msgs") == "pip install ros-jazzy-geometry-msgs"
    assert install_hint("python3-numpy").startswith("pip install numpy")
    assert "source the underlay that has it" in install_hint("turtlesim")


# ------------------------------------------------------------------------------ a build

#: installs a file, finds nothing: whatever it declares, it builds
DATA_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
install(FILES package.xml DESTINATION share/{name})
"""

#: needs its declared dependency for real
NEEDY_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
find_package(frobnicator REQUIRED)
"""


def test_unresolved_dependencies_warn_once_and_the_build_goes_on(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    runtime = write_cmake(ws / "src", "launch_only", DATA_CMAKE.format(name="launch_only"),
                          depend=["turtlesim", "geometry_msgs"])
    (runtime / "package.xml").write_text(package_xml(
        "launch_only", "cmake", depend=["turtlesim", "geometry_msgs"],
        build_depend=["python3-no-such-module"], exec_depend=["rviz2"]))

    result = wsbuild("build", cwd=ws)

    assert result.returncode == 0, output(result)
    lines = result.stdout.splitlines()
    warning = next(i for i, line in enumerate(lines) if line.startswith("WARNING: build dependencies"))
    assert warning < next(i for i, line in enumerate(lines) if line.startswith("Starting"))
    assert lines[warning + 1:warning + 5] == [
        "  launch_only:",
        "    geometry_msgs: pip install ros-jazzy-geometry-msgs",
        "    python3-no-such-module: pip install no-such-module (a rosdep key for a Python package)",
        "    turtlesim: not found: `wsbuild deps install` looks for it (a wheel, a system "
        "package, its sources) and installs it",
    ]
    assert "rviz2" not in result.stdout  # run time only: not the build's business
    assert result.stdout.count("WARNING: build dependencies") == 1
    assert (ws / "install" / "launch_only" / "share" / "launch_only" / "package.xml").is_file()

    quiet = wsbuild("build", "--skip-dependency-check", "--force", cwd=ws)
    assert quiet.returncode == 0 and "WARNING: build dependencies" not in quiet.stdout


def test_a_failed_package_ends_its_report_with_what_it_declared_and_was_not_found(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "needy", NEEDY_CMAKE.format(name="needy"), depend=["frobnicator"])

    result = wsbuild("build", cwd=ws)

    assert result.returncode == 1, output(result)
    report = result.stdout[result.stdout.index("Failed   <<< needy"):]
    report = report[:report.index("  log: ")]
    assert "frobnicatorConfig.cmake" in report  # CMake's own error first
    assert report.rstrip().splitlines()[-1] == (
        "  declares build dependency frobnicator, which was not found: `wsbuild deps install` "
        "looks for it (a wheel, a system package, its sources) and installs it")


def test_strict_dependencies_refuse_before_anything_builds(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "a", DATA_CMAKE.format(name="a"), depend=["turtlesim"])
    write_cmake(ws / "src", "b", DATA_CMAKE.format(name="b"), depend=["turtlesim", "rviz2"])

    result = wsbuild("build", "--strict-dependencies", cwd=ws)

    assert result.returncode == 2, output(result)
    assert "rviz2 (needed by b); turtlesim (needed by a, b)" in result.stderr
    assert "Starting" not in result.stdout
    assert not (ws / "install" / "a").exists()


def test_strict_dependencies_from_the_workspace_defaults_file(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "a", DATA_CMAKE.format(name="a"), depend=["turtlesim"])
    write(ws / "wsbuild.yaml", "build:\n  strict-dependencies: true\n")

    result = wsbuild("build", cwd=ws)

    assert result.returncode == 2, output(result)
    assert "turtlesim (needed by a)" in result.stderr


def test_info_names_the_source_of_each_dependency(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "lib", DATA_CMAKE.format(name="lib"))
    pkg = write_cmake(ws / "src", "app", DATA_CMAKE.format(name="app"))
    (pkg / "package.xml").write_text(package_xml(
        "app", "cmake", depend=["lib", "turtlesim", "python3-pytest"], buildtool=["cmake"]))

    result = wsbuild("info", "app", "--json", cwd=ws)

    assert result.returncode == 0, output(result)
    [record] = json.loads(result.stdout)
    found = {row["name"]: (row["resolution"], row["location"]) for row in record["dependencies"]}
    assert found["lib"] == ("workspace", str(ws / "src" / "lib"))
    assert found["turtlesim"] == ("unresolved", "")
    assert found["python3-pytest"][0] == "python distribution"
    assert found["python3-pytest"][1].startswith("pytest ")
    assert found["cmake"] == ("executable", shutil.which("cmake"))


def test_info_text_shows_the_source_and_where(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    pkg = write_cmake(ws / "src", "app", DATA_CMAKE.format(name="app"))
    (pkg / "package.xml").write_text(package_xml("app", "cmake", depend=["python3-pytest"]))
    result = subprocess.run([sys.executable, "-m", "wsbuild", "info", "app"], cwd=ws,
                            capture_output=True, text=True, check=False)
    line = next(line for line in result.stdout.splitlines() if "python3-pytest" in line)
    assert "python distribution (pytest " in line


@pytest.mark.parametrize(("flag", "where"), [("--strict-dependencies", "--help"),
                                           ("--skip-dependency-check", "--help-all")])
def test_the_flags_are_documented(flag: str, where: str, tmp_path: Path) -> None:
    """--strict-dependencies is on the one-screen help; the colcon-era alias only on --help-all."""
    assert flag in wsbuild("build", where, cwd=tmp_path).stdout
