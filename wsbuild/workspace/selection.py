"""Which packages a run works on: colcon's `--packages-*` options (`SelectionOptions`), the
names they select in topological order, and the `Selection` a verb hands to its work."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass

from wsbuild.errors import SelectionError
from wsbuild.workspace.graph import Graph
from wsbuild.workspace.model import DepCategory, Package
from wsbuild.workspace.root import Workspace


@dataclass(frozen=True, slots=True)
class SelectionOptions:
    """colcon's package selection options (the command line's are read in verbs/arguments.py)."""

    packages_select: tuple[str, ...] | None = None
    packages_skip: tuple[str, ...] = ()
    packages_select_regex: tuple[str, ...] | None = None
    packages_skip_regex: tuple[str, ...] = ()
    packages_up_to: tuple[str, ...] = ()
    packages_up_to_regex: tuple[str, ...] = ()
    packages_above: tuple[str, ...] = ()
    packages_above_and_dependencies: tuple[str, ...] = ()
    packages_above_depth: tuple[str, ...] = ()  # DEPTH PKG...
    packages_select_by_dep: tuple[str, ...] = ()
    packages_skip_by_dep: tuple[str, ...] = ()
    packages_skip_up_to: tuple[str, ...] = ()
    packages_ignore: tuple[str, ...] = ()
    packages_ignore_regex: tuple[str, ...] = ()
    packages_start: str | None = None
    packages_end: str | None = None


def ignored_packages(options: SelectionOptions, packages: Mapping[str, Package]) -> set[str]:
    """Names removed before the graph is built (`--packages-ignore*`)."""
    names = set(packages)
    _check_names(options.packages_ignore, names, "--packages-ignore")
    patterns = _compile(options.packages_ignore_regex, "--packages-ignore-regex")
    return set(options.packages_ignore) | {n for n in names if _matches(patterns, n)}


def select_packages(options: SelectionOptions, graph: Graph) -> list[str]:
    """Apply every selection option (each one narrows the set) and return the topological order."""
    names = set(graph.packages)
    order = graph.topological_order()
    selected = set(names)

    def recursive_deps(targets: Iterable[str]) -> set[str]:
        # colcon: direct dependencies of every category, then run dependencies recursively
        result: set[str] = set()
        for target in targets:
            direct = graph.direct(target)
            result |= direct | graph.dependencies(direct, (DepCategory.RUN,))
        return result

    if options.packages_select is not None or options.packages_select_regex is not None:
        _check_names(options.packages_select or (), names, "--packages-select")
        patterns = _compile(options.packages_select_regex or (), "--packages-select-regex",
                            names)
        selected &= set(options.packages_select or ()) | {
            n for n in names if _matches(patterns, n)
        }
    _check_names(options.packages_skip, names, "--packages-skip")
    skip_patterns = _compile(options.packages_skip_regex, "--packages-skip-regex", names)
    selected -= set(options.packages_skip) | {n for n in names if _matches(skip_patterns, n)}

    up_to = set(_checked(options.packages_up_to, names, "--packages-up-to"))
    up_to_patterns = _compile(options.packages_up_to_regex, "--packages-up-to-regex", names)
    up_to |= {n for n in names if _matches(up_to_patterns, n)}
    if up_to:
        selected &= up_to | _all_recursive(up_to, recursive_deps)

    above = set(_checked(options.packages_above, names, "--packages-above"))
    if above:
        selected &= above | graph.dependents(above)
    above_deps = set(_checked(options.packages_above_and_dependencies, names,
                              "--packages-above-and-dependencies"))
    if above_deps:
        upper = above_deps | graph.dependents(above_deps)
        selected &= upper | _all_recursive(upper, recursive_deps)
    if options.packages_above_depth:
        depth_text, *depth_names = options.packages_above_depth
        if not depth_text.isdigit() or not depth_names:
            raise SelectionError(
                f"--packages-above-depth takes DEPTH PKG..., got '{' '.join(options.packages_above_depth)}'",
                hint="e.g. --packages-above-depth 1 my_pkg",
            )
        base = set(_checked(depth_names, names, "--packages-above-depth"))
        selected &= base | graph.dependents(base, depth=int(depth_text))

    known_deps = names | {d.name for p in graph.packages.values() for d in p.dependencies}
    for option, keep in ((options.packages_select_by_dep, True),
                         (options.packages_skip_by_dep, False)):
        if not option:
            continue
        flag = "--packages-select-by-dep" if keep else "--packages-skip-by-dep"
        deps = set(_checked(option, known_deps, flag))
        matching = {n for n in names if deps & _dependency_names(graph, n, recursive_deps)}
        selected = selected & matching if keep else selected - matching

    skip_up_to = set(_checked(options.packages_skip_up_to, names, "--packages-skip-up-to"))
    if skip_up_to:
        selected -= skip_up_to | _all_recursive(skip_up_to, recursive_deps)

    positions = {name: i for i, name in enumerate(order)}
    if options.packages_start is not None:
        start = _checked((options.packages_start,), names, "--packages-start")[0]
        selected = {n for n in selected if positions[n] >= positions[start]}
    if options.packages_end is not None:
        end = _checked((options.packages_end,), names, "--packages-end")[0]
        selected = {n for n in selected if positions[n] <= positions[end]}
    return [n for n in order if n in selected]


_DepsFn = Callable[[Iterable[str]], set[str]]


def _all_recursive(targets: set[str], recursive_deps: _DepsFn) -> set[str]:
    result: set[str] = set()
    frontier = set(targets)
    while frontier:
        new = recursive_deps(frontier) - result
        result |= new
        frontier = new
    return result


def _dependency_names(graph: Graph, name: str, recursive_deps: _DepsFn) -> set[str]:
    """Every dependency name (workspace or external) of `name` and of its recursive deps."""
    closure = {name} | _all_recursive({name}, recursive_deps)
    result = {d.name for n in closure for d in graph.packages[n].dependencies}
    return (result | closure) - {name}


def _checked(values: Sequence[str], known: set[str], flag: str) -> Sequence[str]:
    _check_names(values, known, flag)
    return values


def _check_names(values: Iterable[str], known: set[str], flag: str) -> None:
    for value in values:
        if value not in known:
            import difflib  # lazy: off every selection that names known packages

            close = difflib.get_close_matches(value, sorted(known), n=3)
            hint = ("did you mean " + ", ".join(f"'{c}'" for c in close) + "?") if close else (
                "run 'wsbuild list -n' to see the package names"
            )
            raise SelectionError(f"{flag}: no package named '{value}' in the workspace", hint=hint)


def _compile(patterns: Iterable[str], flag: str,
             names: set[str] | None = None) -> list[re.Pattern[str]]:
    compiled = []
    for pattern in patterns:
        try:
            regex = re.compile(pattern)
        except re.error as exc:
            raise SelectionError(f"{flag}: invalid regular expression '{pattern}': {exc}") from exc
        if names is not None and not any(regex.match(n) for n in names):
            raise SelectionError(f"{flag}: '{pattern}' matches no package name",
                                 hint="run 'wsbuild list -n' to see the package names")
        compiled.append(regex)
    return compiled


def _matches(patterns: list[re.Pattern[str]], name: str) -> bool:
    return any(p.match(name) for p in patterns)


@dataclass(frozen=True, slots=True)
class Selection:
    """The packages a run works on: the workspace, every package found, their graph, and the
    selected names in the order a run takes them."""

    workspace: Workspace
    packages: Mapping[str, Package]
    graph: Graph
    #: topological order, ties broken by name
    selected: list[str]
