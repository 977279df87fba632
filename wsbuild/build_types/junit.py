"""JUnit XML test results, the common form every test runner reports in: reading and writing them.

A build type's test runner (test_runner.py) reads its tool's results into these types;
`wsbuild test`, `test-result` and the run report read them back."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.files import atomic_write
from wsbuild.words import plural, shorten

if TYPE_CHECKING:
    # imported where used: the build types load this module on every build, which reads no XML
    import xml.etree.ElementTree as ET


class CaseOutcome(Enum):
    PASSED = "passed"
    FAILURE = "failure"
    ERROR = "error"
    SKIPPED = "skipped"


@dataclass(frozen=True, slots=True)
class Counts:
    """How many tests a result holds, by outcome (colcon-test-result's four numbers)."""

    tests: int = 0
    errors: int = 0
    failures: int = 0
    skipped: int = 0

    def __add__(self, other: Counts) -> Counts:
        return Counts(self.tests + other.tests, self.errors + other.errors,
                      self.failures + other.failures, self.skipped + other.skipped)

    @property
    def failed(self) -> bool:
        return bool(self.errors or self.failures)

    def describe(self) -> str:
        """`3 tests, 1 error, 0 failures, 0 skipped`, worded exactly as colcon test-result."""
        return (f"{plural(self.tests, 'test')}, {plural(self.errors, 'error')}, "
                f"{plural(self.failures, 'failure')}, {self.skipped} skipped")

    @classmethod
    def total(cls, counts: Iterable[Counts]) -> Counts:
        """The sum of several results' counts."""
        return sum(counts, cls())

    @classmethod
    def of(cls, cases: Iterable[Case]) -> Counts:
        outcomes = [c.outcome for c in cases]
        return cls(tests=len(outcomes), errors=outcomes.count(CaseOutcome.ERROR),
                   failures=outcomes.count(CaseOutcome.FAILURE),
                   skipped=outcomes.count(CaseOutcome.SKIPPED))


@dataclass(frozen=True, slots=True)
class Case:
    """One `<testcase>` and what happened to it."""

    name: str
    classname: str = ""
    outcome: CaseOutcome = CaseOutcome.PASSED
    #: the `message` attribute of the failure/error/skipped element
    message: str = ""
    #: the text of that element (a traceback, gtest's expectation, ...)
    details: str = ""
    file: str = ""
    line: str = ""
    seconds: float = 0.0
    stdout: str = ""
    stderr: str = ""
    #: the command that ran the test, when the format records it (CTest does)
    command: tuple[str, ...] = ()

    @property
    def full_name(self) -> str:
        """`classname.name`, the name a user searches for (pytest's and gtest's node ids)."""
        if not self.classname or self.name.startswith(self.classname + "."):
            return self.name
        return f"{self.classname}.{self.name}"

    @property
    def label(self) -> str:
        """colcon's label: `classname name (file:line)`."""
        parts = [p for p in (self.classname, self.name) if p]
        if self.file:
            parts.append(f"({self.file}{':' + self.line if self.line else ''})")
        return " ".join(parts)

    @property
    def headline(self) -> str:
        """One line saying why the test failed, for summaries."""
        message = _first_line(self.message)
        if message.endswith(":"):  # "The test did not generate a result file:" and why below
            rest = self.message.split(message, 1)[1]
            why = _first_line(rest) or _telling_line(self.details)
            if why:
                return shorten(f"{message} {why}")
        if message and message.lower() not in _GENERIC_MESSAGES:
            return shorten(message)
        extra = _telling_line(self.details) or _telling_line(self.stdout) \
            or _telling_line(self.stderr)
        return shorten(": ".join(p for p in (message, extra) if p) or self.outcome.value)


# messages that say nothing beyond the outcome; the details then say more
_GENERIC_MESSAGES = frozenset({"", "failed", "failure", "error", "collection failure"})


def _first_line(text: str) -> str:
    for line in text.splitlines():
        if line.strip():
            return line.strip()
    return ""


def _telling_line(text: str) -> str:
    """pytest's last `E   ...` line (the exception), else the last non-blank line."""
    lines = [line.rstrip() for line in text.splitlines() if line.strip()]
    for line in reversed(lines):
        if line.startswith("E "):
            return line[1:].strip()
    return lines[-1].strip() if lines else ""


@dataclass(frozen=True, slots=True)
class ResultFile:
    """The results one file holds."""

    path: Path
    counts: Counts
    cases: tuple[Case, ...] = ()

    def problems(self) -> tuple[Case, ...]:
        """The failed and erroring cases."""
        return tuple(c for c in self.cases
                     if c.outcome in (CaseOutcome.FAILURE, CaseOutcome.ERROR))


class NotJUnit(ValueError):
    """The file is XML but not a JUnit result (e.g. CTest's Test.xml, a launch file)."""


class BadResultFile(ValueError):
    """The file cannot be read as a result file: malformed XML or impossible counts."""


# ------------------------------------------------------------------------------- reading


def read_junit(path: Path) -> ResultFile:
    """Read a JUnit/xUnit file (pytest, gtest, ament, CTest's --output-junit, wsbuild).

    Counts come from the `<testcase>` elements; a suite without any falls back to its
    `tests`/`errors`/`failures`/`skipped`/`disabled` attributes, as colcon-test-result reads them.
    """
    root = parse_xml(path)
    if root.tag == "testsuites":
        suites = [child for child in root if child.tag == "testsuite"]
    elif root.tag == "testsuite":
        suites = [root]
    else:
        raise NotJUnit(f"{path}: the root element is <{root.tag}>, not <testsuite(s)>")
    counts = Counts()
    cases: list[Case] = []
    for suite in suites:
        suite_cases = _suite_cases(suite)
        cases += suite_cases
        counts += Counts.of(suite_cases) if suite_cases else _attribute_counts(suite, path)
    return ResultFile(path, counts, tuple(cases))


def parse_xml(path: Path) -> ET.Element:
    import xml.etree.ElementTree as ET

    try:
        return ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise BadResultFile(f"{path}: malformed XML: {exc}") from None
    except OSError as exc:
        raise BadResultFile(f"{path}: cannot read: {exc.strerror}") from None


def _suite_cases(suite: ET.Element) -> list[Case]:
    cases: list[Case] = []
    for child in suite:
        if child.tag == "testcase":
            cases.append(_case(child))
        elif child.tag == "testsuite":
            cases += _suite_cases(child)
    return cases


def _case(node: ET.Element) -> Case:
    found: dict[str, ET.Element] = {}
    stdout: list[str] = []
    stderr: list[str] = []
    for child in node:
        if child.tag in ("failure", "error", "skipped"):
            found.setdefault(child.tag, child)
        elif child.tag == "system-out" and child.text:
            stdout.append(child.text)
        elif child.tag == "system-err" and child.text:
            stderr.append(child.text)
    # an error outranks a failure (pytest: a failing test whose teardown errors)
    for tag, outcome in (("error", CaseOutcome.ERROR), ("failure", CaseOutcome.FAILURE),
                         ("skipped", CaseOutcome.SKIPPED)):
        if tag in found:
            element = found[tag]
            message, details = element.get("message", ""), element.text or ""
            break
    else:
        # gtest marks DISABLED_ tests status="notrun"; CTest marks them status="disabled"
        skipped = node.get("status") in ("notrun", "disabled") or node.get("result") == "suppressed"
        outcome = CaseOutcome.SKIPPED if skipped else CaseOutcome.PASSED
        message = details = ""
    try:
        seconds = float(node.get("time") or 0)
    except ValueError:
        seconds = 0.0
    return Case(name=node.get("name", ""), classname=node.get("classname", ""), outcome=outcome,
                message=message, details=details.strip("\n"), file=node.get("file", ""),
                line=node.get("line", ""), seconds=seconds, stdout="".join(stdout),
                stderr="".join(stderr))


def _attribute_counts(suite: ET.Element, path: Path) -> Counts:
    values: dict[str, int] = {}
    for attribute in ("tests", "errors", "failures", "skip", "skipped", "disabled"):
        text = suite.get(attribute)
        if text is None:
            if attribute in ("tests", "failures"):
                raise NotJUnit(f"{path}: a <testsuite> has no '{attribute}' attribute")
            continue
        try:
            value = int(text)
        except ValueError:
            raise BadResultFile(f"{path}: '{attribute}' is not an integer: {text!r}") from None
        if value < 0:
            raise BadResultFile(f"{path}: '{attribute}' is negative: {value}")
        values[attribute] = value
    skipped = values.get("skip", 0) + values.get("skipped", 0) + values.get("disabled", 0)
    return Counts(values["tests"], values.get("errors", 0), values["failures"], skipped)


# ------------------------------------------------------------------------------- writing


def write_junit(path: Path, suite: str, cases: Sequence[Case], *, seconds: float = 0.0) -> None:
    """Write `cases` as one `<testsuite>` (atomically: a reader never sees half a file)."""
    import xml.etree.ElementTree as ET

    counts = Counts.of(cases)
    root = ET.Element("testsuite", {
        "name": suite, "tests": str(counts.tests), "errors": str(counts.errors),
        "failures": str(counts.failures), "skipped": str(counts.skipped),
        "time": f"{seconds:.3f}",
    })
    for case in cases:
        attributes = {"classname": case.classname, "name": case.name,
                      "time": f"{case.seconds:.3f}"}
        if case.file:
            attributes["file"] = case.file
        if case.line:
            attributes["line"] = case.line
        node = ET.SubElement(root, "testcase", attributes)
        if case.outcome is not CaseOutcome.PASSED:
            element = ET.SubElement(node, case.outcome.value, {"message": case.message})
            if case.details:
                element.text = case.details
        if case.stdout:
            ET.SubElement(node, "system-out").text = case.stdout
        if case.stderr:
            ET.SubElement(node, "system-err").text = case.stderr
    ET.indent(root)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode")
    atomic_write(path, text + "\n")
