"""The programs the ament linters run, and where each comes from: `wsbuild deps` installs the
missing ones, `wsbuild test` names the one a linter could not find, with the command that
installs it.

A linter's wheel usually brings its Python side (ament_cpplint carries its own cpplint,
ament_flake8 needs flake8, ament_pep257 pydocstyle); the programs below are the ones no wheel
of the `ros` extra installs, or that a machine may lack: without one, the linter's test writes
no result
("The test did not generate a result file: Could not find 'cppcheck' executable").
"""

from __future__ import annotations

import os
import shlex
from collections.abc import Mapping
from dataclasses import dataclass

from wsbuild.patterns import lazy


@dataclass(frozen=True, slots=True)
class LintProgram:
    """A program a linter runs: its name on PATH, or the Python distribution it is."""

    name: str
    #: the Debian package installing it ("" when none: pip only)
    apt: str = ""
    #: the PyPI project installing it ("" when none: apt only)
    pip: str = ""
    #: True: a Python distribution of the venv (checked by name), not a program on PATH
    python: bool = False

    def install_command(self) -> str:
        """What installs it by hand (`sudo apt-get install -y cppcheck`)."""
        if self.apt:
            sudo = "" if os.geteuid() == 0 else "sudo "
            return f"{sudo}apt-get install -y {shlex.quote(self.apt)}"
        return f"pip install {shlex.quote(self.pip)}"


#: the CMake package of each ament linter (underlay/lint.py's LINTERS) -> the program it runs
LINT_PROGRAMS: Mapping[str, LintProgram] = {
    "ament_cmake_cppcheck": LintProgram("cppcheck", apt="cppcheck"),
    "ament_cmake_xmllint": LintProgram("xmllint", apt="libxml2-utils"),
    "ament_cmake_uncrustify": LintProgram("uncrustify", apt="uncrustify"),
    "ament_cmake_clang_format": LintProgram("clang-format", apt="clang-format",
                                            pip="clang-format"),
    "ament_cmake_clang_tidy": LintProgram("clang-tidy", apt="clang-tidy", pip="clang-tidy"),
    "ament_cmake_flake8": LintProgram("flake8", pip="flake8", python=True),
    "ament_cmake_pep257": LintProgram("pydocstyle", pip="pydocstyle", python=True),
    "ament_cmake_pycodestyle": LintProgram("pycodestyle", pip="pycodestyle", python=True),
    "ament_cmake_pyflakes": LintProgram("pyflakes", pip="pyflakes", python=True),
    "ament_cmake_mypy": LintProgram("mypy", pip="mypy", python=True),
}

#: what an ament linter prints when its program is not on PATH
_NOT_FOUND = lazy(r"Could not find '([A-Za-z0-9_.+-]+)' executable")


def missing_program(text: str) -> LintProgram | None:
    """The linter's program a test's output says could not be found, if any (one not in the
    table is named with no install command known: apt's package of the same name)."""
    match = _NOT_FOUND.search(text)
    if match is None:
        return None
    name = match.group(1)
    known = [p for p in LINT_PROGRAMS.values() if p.name == name]
    return known[0] if known else LintProgram(name, apt=name)
