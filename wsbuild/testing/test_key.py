"""A package's test key: what its tests can observe that is known before they run, worked
out for one run from the packages' records (the key's parts, and how a cached result keeps
what the tests were observed to read, are cached_result.py's)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from wsbuild import __version__
from wsbuild.build_types.test_runner import TestContext, TestRunner
from wsbuild.record.model import PackageRecord, read_record
from wsbuild.record.own_files import stat_digest
from wsbuild.record.tested import TestKey
from wsbuild.testing.cached_result import interpreter_tools
from wsbuild.testing.closure import closure_under_test
from wsbuild.testing.underlays import UnderlayPackages

if TYPE_CHECKING:
    from wsbuild.testing.request import TestRequest
    from wsbuild.workspace.selection import Selection


@dataclass(slots=True)
class TestKeys:
    """Makes the packages' test keys of one run, sharing what they have in common: each
    package's record and own files' signatures, the interpreter's tools, the underlays."""

    __test__ = False  # not a pytest test class

    selection: Selection
    request: TestRequest
    merged: bool
    _records: dict[str, PackageRecord | None] = field(default_factory=dict)
    _sources: dict[str, str] = field(default_factory=dict)
    _tools: str = ""
    _underlays: UnderlayPackages | None = None

    def __post_init__(self) -> None:
        self._tools = interpreter_tools(self.request.python_executable)
        self._underlays = UnderlayPackages(self.selection.workspace.install_base)

    def key(self, runner: TestRunner, ctx: TestContext) -> TestKey | None:
        """What the package's tests can observe; None when a package of its test closure was
        not built by wsbuild (no record to compare)."""
        name = ctx.name
        own = self._record(name)
        packages = self.selection.packages
        closure_names = {dep for dep in closure_under_test(self.selection.graph, name)
                         if dep in packages}
        closure = {dep: self._installed_output(dep) for dep in closure_names}
        if own is None or None in closure.values():
            return None
        request = self.request
        observed = runner.key_inputs(ctx)
        # each tool's own arguments only: --pytest-args leave CTest's results valid
        options = [__version__, runner.name, list(ctx.arguments),
                   request.retest_until_fail, request.retest_until_pass, request.strict_linters,
                   str(ctx.results_dir), self.merged, request.python_executable]
        outside = sorted({dep.name for pkg in (name, *closure_names)
                          for dep in packages[pkg].dependencies} - set(packages))
        assert self._underlays is not None
        return TestKey(
            build=own.key, closure={dep: key for dep, key in closure.items() if key is not None},
            sources=stat_digest(packages[name].path, self._outputs(), observed.files),
            options=json.dumps(options),
            tools=json.dumps([self._tools, *observed.tools]),
            underlays=self._underlays.signature(outside, ctx.environ))

    def _outputs(self) -> tuple[str, ...]:
        ws = self.selection.workspace
        return tuple(str(base) for base in (ws.build_base, ws.install_base, ws.log_base))

    def _record(self, name: str) -> PackageRecord | None:
        if name not in self._records:
            self._records[name] = read_record(self.selection.workspace.build_base / name)
        return self._records[name]

    def _installed_output(self, name: str) -> str | None:
        """What stands in for a package's installed output: its record's key, and with a
        symlink install also its own files' signatures (which the install links to)."""
        record = self._record(name)
        if record is None:
            return None
        options = record.settings.get("options")
        if not (isinstance(options, dict) and options.get("symlink_install")):
            return record.key
        if name not in self._sources:
            self._sources[name] = stat_digest(self.selection.packages[name].path,
                                              self._outputs())
        return f"{record.key}+{self._sources[name]}"
