"""testing/missing_linters.py, the pytest plugin `wsbuild test` loads: a test module importing
an ament linter that is not installed is one skipped test saying so, under the ROS tests'
pytest 7 and under the venv's own pytest alike; the other modules run."""

from __future__ import annotations

import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from wsbuild.testing.pytest_env import ros_pytest_dir

COPYRIGHT_TEST = """\
from ament_copyright.main import main
import pytest


@pytest.mark.copyright
@pytest.mark.linter
def test_copyright():
    rc = main(argv=['.', 'test'])
    assert rc == 0, 'Found errors'
"""

# the linter imported through a helper module: only the import itself tells
HELPER = "from ament_xmllint.main import main  # noqa\n"
THROUGH_HELPER = "import helper  # noqa\n\n\ndef test_xmllint():\n    assert helper.main\n"
UNIT_TEST = "def test_sum():\n    assert sum([1, 2]) == 3\n"

PYTESTS = {
    "ROS tests' pytest 7": True,
    "the venv's own pytest": False,
}


def _run(package: Path, ros_pytest: bool, *args: str) -> tuple[int, dict[str, tuple[str, str]]]:
    junit = package / "pytest.xml"
    env = dict(os.environ)
    env.pop("PYTEST_ADDOPTS", None)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(ros_pytest_dir(sys.executable))] * ros_pytest + [str(package / "test")])
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", f"--junit-xml={junit}",
         "--continue-on-collection-errors", "-p", "wsbuild.testing.missing_linters", *args],
        cwd=package, env=env, capture_output=True, text=True, timeout=120, check=False)
    found = {}
    for case in ET.parse(junit).getroot().iter("testcase"):
        state, message = "passed", ""
        for tag in ("failure", "error", "skipped"):
            element = case.find(tag)
            if element is not None:
                state, message = tag, element.get("message", "")
        found[case.get("name", "").split(".")[-1]] = (state, message)
    return done.returncode, found


@pytest.fixture
def package(tmp_path: Path) -> Path:
    test = tmp_path / "pkg" / "test"
    test.mkdir(parents=True)
    (test / "test_copyright.py").write_text(COPYRIGHT_TEST)
    (test / "helper.py").write_text(HELPER)
    (test / "test_xmllint.py").write_text(THROUGH_HELPER)
    (test / "test_sum.py").write_text(UNIT_TEST)
    return tmp_path / "pkg"


@pytest.mark.parametrize("ros_pytest", PYTESTS.values(), ids=PYTESTS.keys())
def test_a_missing_linter_is_a_skip_with_its_name_and_the_rest_runs(
        package: Path, ros_pytest: bool) -> None:
    code, cases = _run(package, ros_pytest)
    assert code == 0
    assert cases == {
        "test_copyright": ("skipped", "not installed, not run: ament_copyright"),
        "test_xmllint": ("skipped", "not installed, not run: ament_xmllint"),
        "test_sum": ("passed", ""),
    }


@pytest.mark.parametrize("ros_pytest", PYTESTS.values(), ids=PYTESTS.keys())
def test_strict_linters_makes_it_a_collection_error_of_that_module_only(
        package: Path, ros_pytest: bool) -> None:
    code, cases = _run(package, ros_pytest, "--wsbuild-strict-linters")
    assert code == 1
    assert cases["test_sum"] == ("passed", "")
    assert cases["test_copyright"] == ("error", "collection failure")
    assert cases["test_xmllint"] == ("error", "collection failure")


def test_a_missing_module_that_is_no_linter_stays_an_error(package: Path) -> None:
    (package / "test" / "test_driver.py").write_text("import serial  # noqa\n")
    code, cases = _run(package, True)
    assert code == 1
    assert cases["test_driver"] == ("error", "collection failure")
    assert cases["test_sum"] == ("passed", "")


def test_a_linter_program_that_is_not_installed_is_not_run_as_a_missing_linter(
        tmp_path: Path) -> None:
    """A new C++ package's `wsbuild test` on a machine without cppcheck (as without root):
    the cppcheck test is not run, counted as skipped and named with the command that installs
    cppcheck and the way to leave the test out; `--require-linters` (for CI) makes it a
    failure; `--ctest-args -E cppcheck` leaves it out."""
    from conftest import run_wsbuild

    hidden = tmp_path / "bin"  # the machine's programs, less cppcheck
    hidden.mkdir()
    for directory in ("/usr/local/bin", "/usr/bin", "/bin"):
        for entry in sorted(Path(directory).iterdir()) if Path(directory).is_dir() else ():
            if entry.name != "cppcheck" and not (hidden / entry.name).exists():
                (hidden / entry.name).symlink_to(entry)
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{hidden}",
           "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": "93"}
    ws = tmp_path / "ws"
    (ws / "src").mkdir(parents=True)
    made = run_wsbuild("pkg", "create", "lint_cpp", "--library-name", "lint", cwd=ws, env=env)
    assert made.returncode == 0, made.stderr
    built = run_wsbuild("build", cwd=ws, env=env)
    assert built.returncode == 0, built.stdout + built.stderr

    tested = run_wsbuild("test", cwd=ws, env=env)
    assert tested.returncode == 0, tested.stdout + tested.stderr
    install = "sudo apt-get install -y cppcheck" if os.geteuid() else "apt-get install -y cppcheck"
    assert ("  not installed, not run: the cppcheck test of lint_cpp (cppcheck is not "
            f"installed): counted as skipped; install it: {install}; or leave the test out: "
            "--ctest-args -E cppcheck; --require-linters makes this a failure") \
        in tested.stdout.splitlines(), tested.stdout
    assert " 0 errors, 0 failures, 1 skipped" in tested.stdout

    required = run_wsbuild("test", "--require-linters", cwd=ws, env=env)
    assert required.returncode == 1, required.stdout
    assert "cppcheck is not installed" in required.stdout
    left_out = run_wsbuild("test", "--ctest-args", "-E", "cppcheck", cwd=ws, env=env)
    assert left_out.returncode == 0 and " 0 skipped" in left_out.stdout, left_out.stdout
