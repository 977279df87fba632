"""Telling "a test failed" from "the test tooling could not start" (a plugin pytest refuses, a
test module or conftest that cannot be imported, a tool that died): the first line of the
cause and the fix, for the summary of `wsbuild test`."""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

from wsbuild.build_types.junit import Case, CaseOutcome
from wsbuild.testing.linters import LINTER_MODULES, STRICT_MESSAGE
from wsbuild.testing.pytest_env import ROS_PYTEST_VERSION, install_hint
from wsbuild.underlay.lint_programs import missing_program

#: the message pytest gives a module it could not collect
COLLECTION_FAILURE = "collection failure"


@dataclass(frozen=True, slots=True)
class ToolingFailure:
    """Why tests could not start, in one line, and what to do about it."""

    what: str
    cause: str
    fix: str
    #: the case that stands for it
    case: str = ""


def is_tooling(case: Case, tool_cases: frozenset[str] = frozenset()) -> bool:
    """Whether a failing case stands for the tooling failing rather than a test: a case the
    package's runner writes when its tool failed (`tool_cases`, TestRunner's), a module that
    could not be collected, a linter whose program is not installed."""
    if case.outcome is not CaseOutcome.ERROR:
        return False
    return (case.name in tool_cases or case.message.strip().lower() == COLLECTION_FAILURE
            or missing_program(f"{case.message}\n{case.details}") is not None)


def tooling_failures(cases: Iterable[Case], python_executable: str,
                     tool_cases: frozenset[str] = frozenset()) -> tuple[ToolingFailure, ...]:
    """The tooling failures among a package's failing cases (`tool_cases`: its runner's)."""
    found = []
    for case in cases:
        if not is_tooling(case, tool_cases):
            continue
        program = missing_program(f"{case.message}\n{case.details}")
        if program is not None:
            found.append(ToolingFailure(
                f"{case.full_name} wrote no result", f"{program.name} is not installed",
                f"{program.install_command()} (wsbuild deps install -y installs the programs "
                "the linters run)", case.full_name))
            continue
        if case.name in tool_cases:
            cause = _cause(case.details) or case.message
            what = case.message  # "pytest exited with code 3 without writing results"
        else:
            cause = _cause(case.details) or case.headline
            what = f"{case.full_name.rstrip('.') or case.classname} could not be collected"
        found.append(ToolingFailure(what, cause, _fix(f"{cause}\n{case.details}",
                                                      python_executable), case.full_name))
    return tuple(found)


# the lines that name what went wrong, best first
_CAUSES = (
    re.compile(r"PluginValidationError: .*"),
    re.compile(r"Error while loading plugin.*"),
    re.compile(r"ImportError while loading conftest.*"),
    re.compile(r"^E\s+(\w+(Error|Exception): .*)", re.MULTILINE),
    re.compile(r"^(\w+(Error|Exception): .*)", re.MULTILINE),
    re.compile(r"No module named .*"),
)


def _cause(text: str) -> str:
    for pattern in _CAUSES:
        match = pattern.search(text)
        if match:
            line = match.group(1) if match.groups() else match.group(0)
            return line.strip().split("\n")[0]
    return ""


def _fix(text: str, python_executable: str) -> str:
    if re.search(r"PluginValidationError|hookimpl|unexpected keyword argument '(fs)?path'",
                 text):
        return (f"ROS 2 Jazzy's pytest plugins need pytest {ROS_PYTEST_VERSION}'s hook "
                f"arguments; install it for the ROS tests: {install_hint(python_executable)}")
    if re.search(r"No module named '?pytest'?\b", text):
        return f"install pytest for the ROS tests: {install_hint(python_executable)}"
    missing = re.search(r"No module named '([\w.]+)'", text)
    if missing and missing.group(1).split(".")[0] in LINTER_MODULES and STRICT_MESSAGE in text:
        return ("install the linter, or test without --strict-linters to count its tests as "
                "skipped")
    if missing:
        module = missing.group(1).split(".")[0]
        return (f"install the Python module '{module}' (pip, or build the workspace package "
                "providing it and declare it as a <test_depend>)")
    if "ImportError while loading conftest" in text:
        return "fix the import in conftest.py (see the log)"
    if "SyntaxError" in text:
        return "fix the syntax error in the test module"
    return "see the log"
