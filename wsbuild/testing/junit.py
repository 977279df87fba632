"""`wsbuild test-result`'s view of a results tree: every JUnit file (and `colcon test`'s CTest
Test.xml) below a folder, each test counted once, and the lines that summarise them.

The JUnit format itself is build_types/junit.py's (test runners write it)."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.build_types.ctest import ament_result_file, read_ctest_xml
from wsbuild.build_types.junit import (
    BadResultFile,
    Case,
    CaseOutcome,
    Counts,
    NotJUnit,
    ResultFile,
    read_junit,
)

# ----------------------------------------------------------------------------- crawling


@dataclass(frozen=True, slots=True)
class Collected:
    """The result files found for a package's tests, and what could not be read."""

    results: tuple[ResultFile, ...]
    warnings: tuple[str, ...] = field(default=())

    @property
    def counts(self) -> Counts:
        return Counts.total(result.counts for result in self.results)


def collect_results(base: Path) -> Collected:
    """Every result under `base`, as `colcon test-result` finds them, each test counted once.

    JUnit files anywhere below `base` (directories starting with a dot skipped), plus the latest
    CTest `Testing/TAG` → `Test.xml` of each package `colcon test` ran CTest in. colcon counts an
    ament test twice (its CTest entry and its own JUnit file); here a CTest entry whose ament
    result file was found is left out.
    """
    results: list[ResultFile] = []
    warnings: list[str] = []
    for path in _xml_files(base):
        try:
            results.append(read_junit(path))
        except NotJUnit:
            continue
        except BadResultFile as exc:
            warnings.append(f"skipping {exc}")
    found = {os.path.normpath(r.path) for r in results}
    for tag in sorted(base.glob("**/Testing/TAG")):
        if any(part.startswith(".") for part in tag.relative_to(base).parts):
            continue
        lines = tag.read_text(errors="replace").splitlines()
        test_xml = tag.parent / (lines[0].strip() if lines else "") / "Test.xml"
        if not lines or not test_xml.is_file():
            warnings.append(f"skipping {tag}: its latest Test.xml is missing")
            continue
        try:
            ctest = read_ctest_xml(test_xml)
        except (NotJUnit, BadResultFile) as exc:
            warnings.append(f"skipping {exc}")
            continue
        kept = tuple(case for case in ctest.cases if not _counted_elsewhere(case, found))
        if kept or not ctest.cases:
            results.append(ResultFile(test_xml, Counts.of(kept), kept))
    results.sort(key=lambda r: str(r.path))
    return Collected(tuple(results), tuple(warnings))


def _counted_elsewhere(case: Case, found: set[str]) -> bool:
    ament = ament_result_file(case.command)
    return (ament is not None and case.outcome is not CaseOutcome.SKIPPED
            and os.path.normpath(ament) in found)


def _xml_files(base: Path) -> list[Path]:
    paths: list[Path] = []
    for dirpath, dirnames, filenames in os.walk(base):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        paths += [Path(dirpath, f) for f in sorted(filenames) if f.endswith(".xml")]
    return paths


# --------------------------------------------------------------------------- summarising


def result_line(label: str, counts: Counts) -> str:
    """`<label>: 3 tests, 1 error, 0 failures, 0 skipped` (colcon test-result's line)."""
    return f"{label}: {counts.describe()}"


def case_details(case: Case) -> list[str]:
    """A failed case as colcon test-result --verbose shows it: label, then marked blocks."""
    lines = [case.label]
    kind = "error" if case.outcome is CaseOutcome.ERROR else "failure"
    lines += _block(f"{kind} message", case.message)
    if case.details.strip() and case.details.strip() != case.message.strip():
        lines += _block(f"{kind} details", case.details)
    lines += _block("stdout output", case.stdout)
    lines += _block("stderr output", case.stderr)
    return lines


def _block(label: str, text: str) -> list[str]:
    if not text.strip("\r\n"):
        return []
    return [f"<<< {label}", *(f"  {line}" for line in text.strip("\r\n").splitlines()), ">>>"]


def report_lines(collected: Collected, *, show_all: bool, verbose: bool,
                 files_only: bool, shown: Path) -> list[str]:
    """What `wsbuild test-result` prints: colcon test-result's output, paths relative to `shown`."""
    listed = [r for r in collected.results if r.counts.failed or show_all]
    lines: list[str] = []
    for result in listed:
        label = display_path(result.path, shown)
        if files_only:
            lines.append(label)
            continue
        lines.append(result_line(label, result.counts))
        if verbose:
            for case in result.problems():
                for index, line in enumerate(case_details(case)):
                    lines.append(("- " if index == 0 else "  ") + line)
    if not files_only:
        if listed:
            lines.append("")
        lines.append(result_line("Summary", collected.counts))
    return lines


def display_path(path: Path, base: Path) -> str:
    """`path` relative to `base` when inside it (as a user typed it), else absolute."""
    try:
        return str(path.relative_to(base))
    except ValueError:
        return str(path)
