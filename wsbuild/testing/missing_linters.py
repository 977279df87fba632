"""A pytest plugin `wsbuild test` loads into each package's pytest run (`-p`): a test module
that cannot be imported because an ament linter is not installed becomes one skipped test
saying so ("not installed, not run: ament_copyright"), so it neither hides the package's other
tests nor passes. With `--wsbuild-strict-linters` the module is a collection error instead
(the other modules still run).

Two places catch it: before any import, a module whose own imports name a linter that is not
installed is collected as that skip (first of all `pytest_pycollect_makemodule` hooks, so a
plugin such as launch_testing, which imports every test module from its hook, never trips over
it); and a module whose import fails later on a missing linter (through a helper) is turned
into the skip from its collection report.

It runs inside the package's test interpreter, under whichever pytest runs there (7.x for
Jazzy's plugins, or newer): it imports only wsbuild's standard-library `linters` module and
uses only hooks and APIs that pytest 7 to 9 share (an old-style hook wrapper, `CollectReport`,
`from_parent`).
"""

from __future__ import annotations

import ast
import importlib.util
from collections.abc import Generator
from pathlib import Path
from typing import Any

import pytest

from wsbuild.testing.linters import LINTER_MODULES, MISSING_LINTER_PREFIX, STRICT_MESSAGE
from wsbuild.patterns import lazy

_NO_MODULE = lazy(r"No module named '(?P<module>[A-Za-z0-9_.]+)'")


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--wsbuild-strict-linters", action="store_true", default=False,
                     help="a test module importing a missing ament linter stays an error")


class LinterNotInstalled(pytest.Item):
    """Stands for a test module whose linter is not installed: skipped with that reason."""

    def __init__(self, *, linter: str, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.linter = linter

    def runtest(self) -> None:
        pytest.skip(MISSING_LINTER_PREFIX + self.linter)

    def reportinfo(self) -> tuple[Any, int | None, str]:
        return self.path, None, self.name


class LinterNotInstalledModule(pytest.File):
    """A test module not imported because a linter it imports is not installed."""

    def __init__(self, *, linter: str, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.linter = linter

    def collect(self) -> list[pytest.Item]:
        if self.config.getoption("wsbuild_strict_linters"):
            raise self.CollectError(f"No module named '{self.linter}': {STRICT_MESSAGE}")
        return [LinterNotInstalled.from_parent(self, name=self.path.stem, linter=self.linter)]


def imported_missing_linter(path: Path) -> str | None:
    """The first ament linter the module imports that is not installed, if any."""
    try:
        tree = ast.parse(path.read_bytes(), filename=str(path))
    except (OSError, SyntaxError, ValueError):
        return None  # pytest reports it as it is
    for node in tree.body:
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names = [node.module]
        else:
            continue
        for name in names:
            top = name.split(".")[0]
            if top in LINTER_MODULES and importlib.util.find_spec(top) is None:
                return top
    return None


@pytest.hookimpl(tryfirst=True)
def pytest_pycollect_makemodule(module_path: Path, parent: pytest.Collector) -> Any:
    linter = imported_missing_linter(module_path)
    if linter is None:
        return None
    return LinterNotInstalledModule.from_parent(parent, path=module_path, linter=linter)


def missing_linter(text: str) -> str | None:
    """The ament linter an import error says is missing, if it is one."""
    for match in _NO_MODULE.finditer(text):
        module = match["module"].split(".")[0]
        if module in LINTER_MODULES:
            return module
    return None


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector: pytest.Collector) -> Generator[None, Any, None]:
    outcome = yield
    report = outcome.get_result()
    if not report.failed or not isinstance(collector, pytest.Module):
        return
    if collector.config.getoption("wsbuild_strict_linters"):
        return
    linter = missing_linter(str(report.longrepr))
    if linter is None:
        return
    item = LinterNotInstalled.from_parent(collector, name=collector.path.stem, linter=linter)
    outcome.force_result(pytest.CollectReport(report.nodeid, "passed", None, [item]))
