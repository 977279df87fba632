"""The oracle that holds the no-op record honest (engine/inputs_oracle.py): while on, it notes
every file the process stats, lists or opens, and at the end writes down each one that no
declaration (wsbuild/inputs.py) covers; the suite fails when it wrote anything
(tests/conftest.py)."""

from __future__ import annotations

import os
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
