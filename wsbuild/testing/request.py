"""What a `wsbuild test` run was asked to do: the frozen request `verbs/test.py` makes of the
command line and colcon.meta (the verb boundary), which the test run, the tester and the
cached result's key read."""

from __future__ import annotations

import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True, slots=True)
class TestRequest:
    """The options of `wsbuild test` that shape the run."""

    __test__ = False  # not a pytest test class

    #: a test tool's name ("pytest", "ctest", a plugin runner's) → the command line's
    #: arguments for it (--pytest-args, --ctest-args)
    tool_arguments: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    #: package name → tool name → the arguments its colcon.meta adds (after the command line's,
    #: as colcon extends lists with meta values)
    package_arguments: Mapping[str, Mapping[str, tuple[str, ...]]] = field(default_factory=dict)
    retest_until_fail: int = 0
    retest_until_pass: int = 0
    #: results go to <test_result_base>/<pkg>/ instead of <build>/<pkg>/test_results/<pkg>/
    test_result_base: Path | None = None
    #: None: whatever install/ holds (its layout marker)
    merge_install: bool | None = None
    workers: int = 1
    abort_on_error: bool = False
    wait_for_lock: bool = True
    python_executable: str = sys.executable
    #: a test module importing an ament linter that is not installed is an error, not a skip
    strict_linters: bool = False
    #: --env-ignore: variables that reach no test, beside record/environment.py's own list
    env_ignore: tuple[str, ...] = ()
    #: reuse a package's last passing result while nothing its tests observe changed
    #: (cached_result.py); False: --no-test-cache
    reuse_results: bool = True
    #: log/<run>/report.json and report.html (--no-report: off; timings.json is always written)
    report: bool = True

    @property
    def max_attempts(self) -> int:
        return 1 + max(self.retest_until_fail, self.retest_until_pass)
