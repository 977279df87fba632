"""A package's own options: colcon.meta's `cmake-args` and `ament-cmake-args` (and the command
line's --ament-cmake-args) reach only the packages they are for, after the command line's
--cmake-args as colcon extends a list option with a package's metadata, and enter only those
packages' build keys: changing them rebuilds those packages and no other."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from conftest import run_wsbuild


def cache_entry(build_dir: Path, name: str) -> str | None:
    """The value CMakeCache.txt holds for `name` (None: not set)."""
    for line in (build_dir / "CMakeCache.txt").read_text().splitlines():
        if line.startswith(f"{name}:"):
            return line.partition("=")[2]
    return None


def started(stdout: str) -> list[str]:
    return sorted(line.split()[-1] for line in stdout.splitlines()
                  if line.startswith("Starting >>>"))


def write_meta(ws: Path, names: dict[str, dict[str, list[str]]]) -> None:
    (ws / "colcon.meta").write_text(json.dumps({"names": names}))


def test_a_package_define_reaches_only_its_package_and_rebuilds_only_it(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pa": ("cmake", []), "pb": ("cmake", [])})
    write_meta(ws, {"pa": {"cmake-args": ["-DFOO=1"]}})
    first = run_wsbuild("build", "--cmake-args", "-DFOO=0", "-DSHARED=yes", "--", cwd=ws)
    assert first.returncode == 0, first.stdout + first.stderr
    # colcon's order: the package's metadata after the command line's, so it wins
    assert cache_entry(ws / "build" / "pa", "FOO") == "1"
    assert cache_entry(ws / "build" / "pb", "FOO") == "0"
    assert cache_entry(ws / "build" / "pa", "SHARED") == "yes"
    assert cache_entry(ws / "build" / "pb", "SHARED") == "yes"
    assert "colcon.meta" not in first.stdout + first.stderr  # applied: no note

    write_meta(ws, {"pa": {"cmake-args": ["-DFOO=2"]}})
    dry = run_wsbuild("build", "--dry-run", "--json", "--cmake-args", "-DFOO=0",
                      "-DSHARED=yes", "--", cwd=ws)
    assert dry.returncode == 0, dry.stdout + dry.stderr
    plan = {p["name"]: p for p in json.loads(dry.stdout)["packages"]}
    assert plan["pb"]["up_to_date"] is True and plan["pb"]["reason"] is None
    assert plan["pa"]["reason"]["kind"] == "options"
    assert plan["pa"]["reason"]["details"] == [
        "cmake_args: [-DFOO=0, -DSHARED=yes, -DFOO=1] → [-DFOO=0, -DSHARED=yes, -DFOO=2]"]

    again = run_wsbuild("build", "--cmake-args", "-DFOO=0", "-DSHARED=yes", "--", cwd=ws)
    assert again.returncode == 0, again.stdout + again.stderr
    assert started(again.stdout) == ["pa"]
    assert cache_entry(ws / "build" / "pa", "FOO") == "2"
    assert cache_entry(ws / "build" / "pb", "FOO") == "0"


def test_the_cache_selection_judges_each_package_with_its_own_options(
        make_workspace: Callable[..., Path]) -> None:
    """colcon-cache's --packages-select-cache-invalid plans as `build` would: with colcon.meta's
    options of each package, so a package built with them is valid until they change."""
    ws = make_workspace({"pa": ("cmake", []), "pb": ("cmake", [])})
    write_meta(ws, {"pa": {"cmake-args": ["-DFOO=1"]}})
    assert run_wsbuild("build", cwd=ws).returncode == 0

    def invalid() -> list[str]:
        listed = run_wsbuild("list", "-n", "--packages-select-cache-invalid", cwd=ws)
        assert listed.returncode == 0, listed.stderr
        return listed.stdout.split()

    assert invalid() == []
    write_meta(ws, {"pa": {"cmake-args": ["-DFOO=2"]}})
    assert invalid() == ["pa"]
    built = run_wsbuild("build", "--packages-select-cache-invalid", cwd=ws)
    assert built.returncode == 0, built.stdout + built.stderr
    assert started(built.stdout) == ["pa"]


def test_any_cmake_argument_of_a_package_reaches_it_not_only_defines(
        make_workspace: Callable[..., Path]) -> None:
    """No longer a `-C` script of `-D` settings: `-U`, `-W…` and the like reach the package."""
    ws = make_workspace({"pa": ("cmake", []), "pb": ("cmake", [])})
    write_meta(ws, {"pa": {"cmake-args": ["-Wno-dev", "-DBAR:BOOL=ON"]}})
    result = run_wsbuild("build", "--dry-run", "--commands", cwd=ws)
    assert result.returncode == 0, result.stdout + result.stderr
    configure = [line for line in result.stdout.splitlines() if " cmake " in f" {line} "
                 and "CMAKE_INSTALL_PREFIX" in line]
    [pa_line] = [line for line in configure if "/pa" in line.split("CMAKE_INSTALL_PREFIX")[1]
                 .split()[0]]
    [pb_line] = [line for line in configure if line is not pa_line]
    assert pa_line.endswith("-Wno-dev -DBAR:BOOL=ON")
    assert "-Wno-dev" not in pb_line and "BAR" not in pb_line
    assert "ignored" not in result.stderr


def test_ament_cmake_args_reach_ament_cmake_packages_only(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pa": ("ament_cmake", []), "pc": ("cmake", [])})
    write_meta(ws, {"pa": {"ament-cmake-args": ["-DMETA=here"]},
                    "pc": {"ament-cmake-args": ["-DMETA=here"]}})
    result = run_wsbuild("build", "--ament-cmake-args", "-DAMENT=on", "--", cwd=ws)
    assert result.returncode == 0, result.stdout + result.stderr
    assert cache_entry(ws / "build" / "pa", "AMENT") == "on"
    assert cache_entry(ws / "build" / "pa", "META") == "here"
    assert cache_entry(ws / "build" / "pc", "AMENT") is None
    assert cache_entry(ws / "build" / "pc", "META") is None
    # --ament-cmake-args are none of a plain CMake package's business: it stays up to date
    changed = run_wsbuild("build", "--ament-cmake-args", "-DAMENT=off", "--", cwd=ws)
    assert changed.returncode == 0, changed.stdout + changed.stderr
    assert started(changed.stdout) == ["pa"]
    assert cache_entry(ws / "build" / "pa", "AMENT") == "off"


def test_a_key_wsbuild_does_not_apply_is_named(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pa": ("cmake", [])})
    (ws / "colcon.meta").write_text(json.dumps(
        {"names": {"pa": {"symlink-install": True, "pytest-args": ["-x"]}}}))
    result = run_wsbuild("build", "--dry-run", "--commands", cwd=ws)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "colcon.meta: 'symlink-install' of pa is ignored" in result.stderr
    assert "'pytest-args' of pa" not in result.stderr  # `wsbuild test` applies it


TWO_TESTS = "def test_fine():\n    pass\n\n\ndef test_broken():\n    assert False\n"


def test_a_packages_pytest_args_reach_only_its_tests(
        make_workspace: Callable[..., Path]) -> None:
    """colcon.meta's `pytest-args` of one package (after --pytest-args) reach its pytest only,
    and enter only its test key: another package's change of them leaves its result reused."""
    ws = make_workspace({"pa": ("ament_python", []), "pb": ("ament_python", [])})
    for name in ("pa", "pb"):
        (ws / "src" / name / "test").mkdir()
        (ws / "src" / name / "test" / "test_two.py").write_text(TWO_TESTS)
    built = run_wsbuild("build", cwd=ws)
    assert built.returncode == 0, built.stdout + built.stderr
    write_meta(ws, {"pa": {"pytest-args": ["-k", "not broken"]}})
    tested = run_wsbuild("test", "--pytest-args", "-k", "fine or broken", "--", cwd=ws)
    assert tested.returncode == 1, tested.stdout + tested.stderr  # pb's broken test still runs
    lines = tested.stdout.splitlines()
    assert any(line.startswith("Finished <<< pa") for line in lines), tested.stdout
    assert any(line.startswith("Failed   <<< pb") and line.endswith("1 failure")
               for line in lines), tested.stdout
    assert "colcon.meta" not in tested.stderr
    assert "not broken" in (ws / "log" / "latest_test" / "pa" / "command.log").read_text()
    assert "not broken" not in (ws / "log" / "latest_test" / "pb" / "command.log").read_text()

    write_meta(ws, {"pa": {"pytest-args": ["-k", "not broken"]}, "pb": {"pytest-args": ["-x"]}})
    again = run_wsbuild("test", "--pytest-args", "-k", "fine or broken", "--", cwd=ws)
    assert again.returncode == 1, again.stdout + again.stderr
    lines = again.stdout.splitlines()
    assert any(line.startswith("[pa] cached: 1 test,") for line in lines), again.stdout
    assert "Starting >>> pb" in lines and "Starting >>> pa" not in lines
