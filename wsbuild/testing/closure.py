"""What a package's tests run against (its test closure), and the check that all of it is built."""

from __future__ import annotations

from typing import TYPE_CHECKING

from wsbuild.build_types import get_build_type
from wsbuild.errors import WorkspaceError
from wsbuild.prefix.layout import is_installed
from wsbuild.workspace.graph import Graph
from wsbuild.workspace.model import DepCategory

if TYPE_CHECKING:
    from wsbuild.workspace.selection import Selection


def closure_under_test(graph: Graph, name: str) -> set[str]:
    """What a package's tests run against besides itself: its direct dependencies of every
    category and, recursively, their run dependencies (colcon test's recursive_categories=run)."""
    result: set[str] = set()
    stack = list(graph.direct(name))
    while stack:
        dep = stack.pop()
        if dep not in result and dep != name:
            result.add(dep)
            stack.extend(graph.direct(dep, (DepCategory.RUN,)))
    return result


def check_built(selection: Selection, merged: bool) -> None:
    """Refuse to test packages that are not built, or whose test environment is not: all at
    once. A package is built when it is installed and its build left what its test runner
    needs (CTest: a configured build directory)."""
    missing: dict[str, set[str]] = {}
    install_base = selection.workspace.install_base
    for name in selection.selected:
        for dep in sorted({name} | closure_under_test(selection.graph, name)):
            if not is_installed(install_base, dep, merged=merged):
                missing.setdefault(dep, set()).add(name)
        runner = get_build_type(selection.packages[name].build_type).test_runner
        if runner is not None and not runner.built(selection.workspace.build_base / name):
            missing.setdefault(name, set()).add(name)
    if not missing:
        return
    items = "; ".join(
        dep if users == {dep} else f"{dep} (needed to test {', '.join(sorted(users - {dep}))})"
        for dep, users in sorted(missing.items()))
    raise WorkspaceError(
        f"not built: {items}",
        hint=f"build first: wsbuild build --packages-up-to {' '.join(sorted(missing))}",
    )
