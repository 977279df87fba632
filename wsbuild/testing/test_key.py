"""A package's test key: everything its tests can observe, worked out for one run (the key's
parts and how a cached result is kept are cached_result.py's)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from wsbuild import __version__
from wsbuild.build_types.test_runner import TestContext, TestRunner
from wsbuild.testing.cached_result import (
    BuildRecord,
    TestKey,
    interpreter_tools,
    observed_environment,
    read_build_record,
    source_signature,
)
from wsbuild.testing.closure import closure_under_test
from wsbuild.testing.pytest_env import ros_pytest_dir

if TYPE_CHECKING:
    from wsbuild.testing.runners import TestRequest
    from wsbuild.workspace.selection import Selection


@dataclass(slots=True)
class TestKeys:
    """Makes the packages' test keys of one run, sharing what they have in common: each
    package's build record and source signature, the interpreter's tools."""

    __test__ = False  # not a pytest test class

    selection: Selection
    request: TestRequest
    merged: bool
    _builds: dict[str, BuildRecord | None] = field(default_factory=dict)
    _sources: dict[str, str] = field(default_factory=dict)
    _tools: str = ""

    def __post_init__(self) -> None:
        self._tools = interpreter_tools(self.request.python_executable,
                                        ros_pytest_dir(self.request.python_executable))

    def key(self, runner: TestRunner, ctx: TestContext) -> TestKey | None:
        """What the package's tests can observe; None when a package of its test closure was
        not built by wsbuild (no build key to compare)."""
        name = ctx.name
        own = self._build(name)
        closure = {dep: self._installed_output(dep) for dep in
                   closure_under_test(self.selection.graph, name) if dep in self.selection.packages}
        if own is None or None in closure.values():
            return None
        request = self.request
        observed = runner.key_inputs(ctx)
        # each tool's own arguments only: --pytest-args leave CTest's results valid
        options = [__version__, runner.name, list(ctx.arguments),
                   request.retest_until_fail, request.retest_until_pass, request.strict_linters,
                   str(ctx.results_dir), self.merged, request.python_executable]
        return TestKey(
            build=own.key, closure={dep: key for dep, key in closure.items() if key is not None},
            sources=source_signature(self.selection.packages[name].path, observed.files),
            options=json.dumps(options), environment=observed_environment(ctx.environ),
            tools=json.dumps([self._tools, *observed.tools]))

    def _build(self, name: str) -> BuildRecord | None:
        if name not in self._builds:
            self._builds[name] = read_build_record(self.selection.workspace.build_base / name)
        return self._builds[name]

    def _installed_output(self, name: str) -> str | None:
        """What stands in for a package's installed output: its build key, and with a
        symlink install also its sources (which the install links to)."""
        build = self._build(name)
        if build is None:
            return None
        if not build.symlink_install:
            return build.key
        if name not in self._sources:
            self._sources[name] = source_signature(self.selection.packages[name].path)
        return f"{build.key}+{self._sources[name]}"

