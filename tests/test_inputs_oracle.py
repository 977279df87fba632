"""The oracle that holds the no-op record honest (engine/inputs_oracle.py): while on, it notes
every file the process stats, lists or opens, and at the end writes down each one that no
declaration (wsbuild/inputs.py) covers; the suite fails when it wrote anything
(tests/conftest.py)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from wsbuild.engine.inputs_oracle import InputsOracle


def test_the_oracle_names_what_was_read_without_being_declared(tmp_path: Path) -> None:
    declared, undeclared, listed = tmp_path / "declared", tmp_path / "undeclared", tmp_path / "d"
    declared.write_text("a")
    undeclared.write_text("b")
    listed.mkdir()
    oracle_file = tmp_path / "oracle.txt"
    oracle = InputsOracle(str(oracle_file), str(tmp_path))
    oracle.install()
    try:
        declared.read_text()
        os.stat(declared)
        undeclared.read_text()
        sorted(listed.iterdir())
        os.listdir(tmp_path)
    finally:
        oracle.uninstall()
    undeclared.read_text()  # after uninstall: not traced
    oracle.report_undeclared({(str(declared), True): None}, {str(listed)}, ())
    lines = [line.split("\t")[:2] for line in oracle_file.read_text().splitlines()
             if not line.startswith("#")]
    assert lines == [[str(undeclared), "stat"], [str(tmp_path), "listing"]]


def test_the_oracle_writes_nothing_when_every_access_was_declared(tmp_path: Path) -> None:
    file = tmp_path / "f"
    file.write_text("a")
    oracle_file = tmp_path / "oracle.txt"
    oracle = InputsOracle(str(oracle_file), str(tmp_path))
    oracle.install()
    try:
        file.read_text()
    finally:
        oracle.uninstall()
    oracle.report_undeclared({(str(file), True): None}, set(), ())
    assert not oracle_file.exists()


def test_the_oracle_exempts_the_standard_library_only(tmp_path: Path) -> None:
    """What the interpreter's standard library reads is exempt; nothing else of its prefix is
    (for a venv made from /usr/bin/python3, `sys.base_prefix` is /usr: its headers, CMake
    modules and .pc files are inputs a plan must declare), and its site-packages never are,
    wherever they lie (the ROS wheels, ament_index_python's resources)."""
    import sysconfig

    stdlib_file = os.path.join(sysconfig.get_paths()["stdlib"], "os.py")
    beside = next(p for p in (Path(sys.base_prefix) / "include").rglob("*.h"))
    site = Path(sysconfig.get_paths()["purelib"])
    in_site = next(site.glob("*.dist-info")) / "METADATA"
    oracle_file = tmp_path / "oracle.txt"
    oracle = InputsOracle(str(oracle_file), str(tmp_path))
    oracle.install()
    try:
        os.stat(stdlib_file)
        os.stat(beside)
        os.stat(in_site)
        os.listdir(site)
    finally:
        oracle.uninstall()
    oracle.report_undeclared({}, set(), ())
    flagged = sorted(line.split("\t")[0] for line in oracle_file.read_text().splitlines()
                     if not line.startswith("#"))
    assert flagged == sorted([str(beside), str(in_site), str(site)])


def test_the_inputs_oracle_is_on_for_the_suites_recorded_runs(tmp_path: Path) -> None:
    """The suite sets the oracle's file (tests/conftest.py) and every recorded run it traced
    says so beside it, with how many accesses it held to the declarations: with the oracle
    off (the variable unset, or its wrappers not installed) this fails."""
    from conftest import run_wsbuild, write_package
    from wsbuild.engine.inputs_oracle import CHECKED_SUFFIX, ORACLE_VARIABLE

    assert os.environ.get(ORACLE_VARIABLE), "the suite runs without the inputs oracle"
    checked = Path(os.environ[ORACLE_VARIABLE] + CHECKED_SUFFIX)
    ws = tmp_path / "ws"
    write_package(ws / "src", "pa", "cmake")
    result = run_wsbuild("list", cwd=ws)
    assert result.returncode == 0, result.stderr
    lines = [line.split("\t") for line in checked.read_text().splitlines()]
    mine = [line for line in lines if line[3] == str(ws) and line[2] == "list"]
    assert mine and int(mine[-1][0]) > 0, lines[-3:]
    assert mine[-1][1] == "0"
