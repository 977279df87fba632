"""The CMake build types' tests: CTest in the configured build directory, its JUnit read back,
each ament test's own JUnit file standing in for its CTest entry (so no test counts twice);
and CTest's own result formats (its JUnit, the Test.xml `colcon test` makes it write)."""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from wsbuild import inputs
from wsbuild.build_types import Command
from wsbuild.build_types.junit import (
    BadResultFile,
    Case,
    CaseOutcome,
    Counts,
    NotJUnit,
    ResultFile,
    parse_xml,
    read_junit,
    write_junit,
)
from wsbuild.build_types.test_runner import (
    KeyInputs,
    TestContext,
    TestOutcome,
    TestRunnerBase,
    tool_error,
)
from wsbuild.patterns import lazy

#: CTest's exit code when some tests failed (anything else non-zero is CTest itself failing)
CTEST_TESTS_FAILED = 8

# "  3/4 Test  #3: name ..........***Timeout   1.00 sec": CTest's verdict, which its JUnit lacks
_CTEST_VERDICT = lazy(
    r"^\s*\d+/\d+ Test\s+#\d+: (?P<name>\S+) \.*\s*\*\*\*(?P<verdict>.+?)\s+[\d.]+ sec")


@dataclass(frozen=True, slots=True)
class CTestRunner(TestRunnerBase):
    """CTest, with the package's install on the environment as colcon runs it."""

    name: str = "ctest"

    def built(self, build_dir: Path) -> bool:
        """A configured build tree; or a restore from the build cache of a package whose tests
        are not in its build tree (no CTestTestfile.cmake: it enables no testing)."""
        if (build_dir / "CMakeCache.txt").is_file():
            return True
        from wsbuild.record.model import read_record  # lazy: off `test-result`

        record = read_record(build_dir)
        return record is not None and not record.test_tree

    @property
    def tool_cases(self) -> frozenset[str]:
        return frozenset({"ctest.exit_code", "ctest.result"})

    def environment(self, env: Mapping[str, str], python_executable: str) -> dict[str, str]:
        """The package's test environment, with the ROS tests' pytest first on PYTHONPATH for
        the pytest tests CTest runs (ament_cmake_pytest)."""
        from wsbuild.build_types.ros_pytest import with_ros_pytest  # lazy: off `test-result`

        return with_ros_pytest(env, python_executable)

    def tests_in_build_tree(self, build_dir: Path) -> bool:
        """Whether a CTestTestfile.cmake of the tree declares a test (ament_cmake enables
        testing in every package; one without tests declares none)."""
        for directory, names, files in os.walk(build_dir):
            names[:] = [n for n in names if n != "CMakeFiles"]
            if "CTestTestfile.cmake" in files:
                try:
                    text = Path(directory, "CTestTestfile.cmake").read_text(errors="replace")
                except OSError:
                    continue
                if "add_test(" in text:
                    return True
        return False

    def key_inputs(self, ctx: TestContext) -> KeyInputs:
        ctest = inputs.which("ctest", path=ctx.environ.get("PATH"))
        return KeyInputs(
            tools=(f"{ctest}:{inputs.signature(ctest) if ctest else ''}",),
            files=(ctx.build_dir / "CTestTestfile.cmake", ctx.build_dir / ".ninja_log"))

    def command(self, ctx: TestContext) -> Command:
        return Command((_ctest(ctx), "-C", cmake_config(ctx.build_dir), "--output-on-failure",
                        "--force-new-ctest-process", "--output-junit", str(_raw_junit(ctx)),
                        *ctx.arguments), ctx.build_dir)

    def run(self, ctx: TestContext) -> TestOutcome:
        name, build_dir = ctx.name, ctx.build_dir
        ctest_xml = ctx.results_dir / "ctest.xml"
        if not (build_dir / "CTestTestfile.cmake").is_file():
            ctest_xml.unlink(missing_ok=True)
            return TestOutcome(no_tests="no tests (no CTestTestfile.cmake: testing not enabled)")
        listed = _test_commands(ctx)
        if listed == {}:
            ctest_xml.unlink(missing_ok=True)
            return TestOutcome(no_tests="no tests found by CTest")
        # unknown when CTest cannot list them: then no ament result file stands in
        commands = listed or {}
        tag = build_dir / "Testing" / "TAG"
        if tag.is_file():
            # points colcon test-result at the Test.xml of an earlier `colcon test`: stale now
            tag.unlink()
        raw = _raw_junit(ctx)
        raw.parent.mkdir(parents=True, exist_ok=True)
        raw.unlink(missing_ok=True)
        verdicts: dict[str, str] = {}

        def on_line(text: str, is_err: bool) -> None:
            match = _CTEST_VERDICT.match(text)
            if match:
                verdicts[match["name"]] = match["verdict"]

        completed = ctx.run(self.command(ctx), on_line=on_line)
        code = completed.returncode
        own: list[Case] = []
        files: list[ResultFile] = []
        ran: ResultFile | None = None
        if raw.is_file():
            try:
                ran = read_ctest_junit(raw)
            except (NotJUnit, BadResultFile) as exc:
                own.append(Case(name="ctest.result", classname=name, outcome=CaseOutcome.ERROR,
                                message=f"CTest wrote an unreadable result file: {exc}"))
        for case in ran.cases if ran is not None else ():
            case = replace(case, classname=name, command=commands.get(case.name, ()))
            if case.outcome is CaseOutcome.FAILURE and not case.message:
                case = replace(case, message=verdicts.get(case.name, "Failed"))
            ament = ament_result_file(case.command)
            ran_it = case.outcome in (CaseOutcome.PASSED, CaseOutcome.FAILURE)
            if ament is None or not ran_it or not ament.is_file():
                own.append(case)
                continue
            try:
                result = read_junit(ament)
            except (NotJUnit, BadResultFile) as exc:
                own.append(replace(case, outcome=CaseOutcome.ERROR,
                                   message=f"unreadable result file: {exc}"))
                continue
            files.append(_publish(result, ctx.results_dir))
            if case.outcome is CaseOutcome.FAILURE and not result.counts.failed:
                # e.g. a crash after gtest wrote its report: CTest's verdict stands
                own.append(replace(case, message=f"{case.message}, although {ament.name} "
                                                 "reports no failures"))
        problems_seen = any(c.outcome in (CaseOutcome.FAILURE, CaseOutcome.ERROR) for c in own) \
            or any(f.counts.failed for f in files)
        if ran is None or code not in (0, CTEST_TESTS_FAILED) or \
                (code == CTEST_TESTS_FAILED and not problems_seen):
            suffix = "" if ran is not None else "without writing results"
            own.append(tool_error("ctest", code, completed, "ctest.exit_code", name, suffix))
        if ran is not None and ran.counts.tests == 0 and not own:
            ctest_xml.unlink(missing_ok=True)
            return TestOutcome(no_tests="no tests run by CTest")
        if own:
            write_junit(ctest_xml, name, own)
            files.insert(0, ResultFile(ctest_xml, Counts.of(own), tuple(own)))
        else:
            ctest_xml.unlink(missing_ok=True)
        return TestOutcome(tuple(files))


def _ctest(ctx: TestContext) -> str:
    return shutil.which("ctest", path=ctx.environ.get("PATH")) or "ctest"


def _raw_junit(ctx: TestContext) -> Path:
    """Where CTest writes its own JUnit (read, then split into ctest.xml and ament's files)."""
    return ctx.build_dir / ".wsbuild" / "ctest-junit.xml"


def _test_commands(ctx: TestContext) -> dict[str, tuple[str, ...]] | None:
    """Every CTest test's command line (None when CTest cannot list them)."""
    lines: list[str] = []

    def on_line(text: str, is_err: bool) -> None:
        if not is_err:
            lines.append(text)

    completed = ctx.run(Command((_ctest(ctx), "--show-only=json-v1"), ctx.build_dir),
                        on_line=on_line, logged=False)
    if completed.returncode != 0:
        return None
    try:
        tests = json.loads("\n".join(lines)).get("tests", [])
    except ValueError:
        return None
    return {str(t.get("name", "")): tuple(t.get("command") or ()) for t in tests}


def cmake_config(build_dir: Path) -> str:
    """The configuration CTest runs (needed by multi-config generators), chosen as colcon does."""
    try:
        text = (build_dir / "CMakeCache.txt").read_text(errors="replace")
    except OSError:
        return "Release"
    match = re.search(r"^CMAKE_BUILD_TYPE:[A-Z]*=(.*)$", text, re.MULTILINE)
    value = match.group(1).strip() if match else ""
    return value if value in ("Debug", "MinSizeRel", "RelWithDebInfo") else "Release"


def _publish(result: ResultFile, target: Path) -> ResultFile:
    """An ament JUnit file, copied into --test-result-base when that is elsewhere."""
    if result.path.parent == target:
        return result
    copy = target / result.path.name
    shutil.copyfile(result.path, copy)
    return replace(result, path=copy)


def is_real_skip(reason: str) -> bool:
    """Whether CTest's reason for not running a test means it was skipped on purpose.

    CTest reports a missing executable, missing REQUIRED_FILES or a failed fixture as
    "not run" (and `--output-junit` even files them as skipped), yet counts them as failed;
    only SKIP_RETURN_CODE, SKIP_REGULAR_EXPRESSION and DISABLED are real skips.
    """
    return reason.startswith("SKIP_") or reason in ("Disabled", "Skipped")


def read_ctest_junit(path: Path) -> ResultFile:
    """Read CTest's `--output-junit` file, turning tests CTest could not run into errors."""
    result = read_junit(path)
    cases = tuple(
        replace(case, outcome=CaseOutcome.ERROR)
        if case.outcome is CaseOutcome.SKIPPED and case.message and not is_real_skip(case.message)
        else case
        for case in result.cases
    )
    return ResultFile(path, Counts.of(cases), cases)




def ament_result_file(command: Sequence[str]) -> Path | None:
    """The JUnit file an ament test writes, read from its CTest command line.

    ament_add_test wraps every test as `python -u run_test.py <RESULT_FILE> --package-name
    <pkg> ...`; that file holds the test's real results (gtest's cases, pytest's cases).
    """
    try:
        index = list(command).index("--package-name")
    except ValueError:
        return None
    if index >= 1 and command[index - 1].endswith(".xml"):
        return Path(command[index - 1])
    return None


def read_ctest_xml(path: Path) -> ResultFile:
    """Read CTest's dashboard `Testing/<tag>/Test.xml` (what `colcon test` makes CTest write)."""
    root = parse_xml(path)
    children = list(root)
    if root.tag != "Site" or len(children) != 1 or children[0].tag != "Testing":
        raise NotJUnit(f"{path}: not a CTest Test.xml (<Site><Testing>...)")
    cases: list[Case] = []
    for test in children[0]:
        if test.tag != "Test":
            continue
        status = test.get("Status")
        if status is None:
            raise BadResultFile(f"{path}: a <Test> has no 'Status' attribute")
        measurements = {m.get("name", ""): (m.findtext("Value") or "")
                        for m in test.iter("NamedMeasurement")}
        output = test.findtext("Results/Measurement/Value") or ""
        completion = measurements.get("Completion Status", "")
        if status == "passed":
            outcome, message = CaseOutcome.PASSED, ""
        elif status == "failed":
            # "Failed" (then "Exit Value" is the exit code), "Timeout", "SEGFAULT", ...
            verdict = measurements.get("Exit Code") or "Failed"
            exit_value = measurements.get("Exit Value")
            message = f"{verdict} (exit code {exit_value})" \
                if verdict == "Failed" and exit_value else verdict
            outcome = CaseOutcome.FAILURE
        elif status == "notrun":
            outcome = CaseOutcome.SKIPPED if is_real_skip(completion) else CaseOutcome.ERROR
            message = completion or "not run"
        else:
            outcome, message = CaseOutcome.ERROR, f"status {status!r}"
        try:
            command = tuple(shlex.split(test.findtext("FullCommandLine") or ""))
        except ValueError:
            command = ()
        try:
            seconds = float(measurements.get("Execution Time") or 0)
        except ValueError:
            seconds = 0.0
        cases.append(Case(name=test.findtext("Name") or "", outcome=outcome, message=message,
                          details=output.strip("\n") if outcome is not CaseOutcome.PASSED else "",
                          seconds=seconds, command=command))
    return ResultFile(path, Counts.of(cases), tuple(cases))


CTEST = CTestRunner()
