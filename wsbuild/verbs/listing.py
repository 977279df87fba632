"""The read-only verbs: `list`, `graph` and `info`."""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.errors import SelectionError
from wsbuild.verbs.arguments import terminal_from_args

if TYPE_CHECKING:  # the modules of the work are imported when a verb runs, not to parse
    from wsbuild.reporter import Terminal
    from wsbuild.workspace.graph import Graph
    from wsbuild.verbs.load import Loaded
    from wsbuild.workspace.model import Package
    from wsbuild.workspace.resolve import Resolver

LIST_DOC = """List the packages of the workspace.

Prints one line per package: name, path (relative to the workspace) and build type.
Packages are found under <workspace>/src (or --base-paths); directories holding a
COLCON_IGNORE, AMENT_IGNORE or CATKIN_IGNORE file are skipped.

examples:
  wsbuild list
  wsbuild list -t --packages-up-to my_robot_bringup
  wsbuild list --deps --packages-select my_node
"""

GRAPH_DOC = """Show the dependency graph among workspace packages.

Text output lists each package (in topological order) with its build, run and test
dependencies inside the workspace. --dot and --mermaid draw build edges solid,
run edges dashed and test edges dotted.
"""

INFO_DOC = """Show everything wsbuild knows about packages.

For each package: path, build type, version, and every dependency by kind with the source
that resolves it, in the words of `wsbuild deps` and the build (workspace, ament index, cmake
config, python distribution, executable, pkg-config, python module, system key not checked,
a linter stood in for by wsbuild) and where, or "unresolved".
"""


def add_list_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-t", "--topological-order", action="store_true",
                        help="dependencies before dependents (default: by name)")
    parser.add_argument("-n", "--names-only", action="store_true",
                        help="only the package names")
    parser.add_argument("-p", "--paths-only", action="store_true",
                        help="only the package paths")
    parser.add_argument("--deps", action="store_true",
                        help="also each dependency and where it resolves")
    parser.add_argument("--json", action="store_true", help="machine-readable output")


def add_graph_arguments(parser: argparse.ArgumentParser) -> None:
    fmt = parser.add_mutually_exclusive_group()
    fmt.add_argument("--dot", action="store_true", help="Graphviz dot output")
    fmt.add_argument("--mermaid", action="store_true", help="Mermaid flowchart output")


def add_info_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("package_names", nargs="*", metavar="PKG",
                        help="package names (default: the selected packages)")
    parser.add_argument("--json", action="store_true", help="machine-readable output")


def _relative(path: Path, root: Path) -> str:
    text, base = str(path), str(root) + os.sep
    if text.startswith(base):  # the common case, without relpath's normalisation work
        return text[len(base):]
    try:
        return os.path.relpath(path, root)
    except ValueError:
        return str(path)


def _read_only(terminal: Terminal, loaded: Loaded) -> None:
    """This run only reads and prints: when it ends well, its record lets the same command on
    an unchanged workspace be replayed (engine/replay.py)."""
    if terminal.recorder is not None:
        terminal.recorder.read_only(build_base=loaded.workspace.build_base)


def run_list(args: argparse.Namespace) -> int:
    """List the selected packages."""
    from wsbuild.verbs.load import load, load_request_from_args  # lazy: off `mixin list`

    terminal = terminal_from_args(args)
    loaded = load(load_request_from_args(args), warn=terminal.warnings, remember=True)
    _read_only(terminal, loaded)
    graph_style = "dot" if getattr(args, "topological_graph_dot", False) else "text" if \
        getattr(args, "topological_graph", False) else None
    if graph_style is not None:  # colcon list -g / --topological-graph-dot
        text = format_graph(loaded.graph, loaded.selected, graph_style)
        if text:
            print(text, file=terminal.stdout)
        return 0
    names = loaded.selected if args.topological_order else sorted(loaded.selected)
    root = loaded.workspace.root
    lookup = _lookup(loaded.workspace.build_base) if args.deps else None
    if args.json:
        rows = []
        for name in names:
            package = loaded.packages[name]
            row: dict[str, object] = {
                "name": name,
                "path": _relative(package.path, root),
                "build_type": package.build_type,
                "version": package.version,
            }
            if lookup is not None:
                row["dependencies"] = _dependency_rows(package, loaded.packages, lookup)
            rows.append(row)
        print(json.dumps(rows, indent=2), file=terminal.stdout)
        return 0
    lines = []
    for name in names:
        package = loaded.packages[name]
        if args.names_only:
            lines.append(name)
        elif args.paths_only:
            lines.append(_relative(package.path, root))
        else:
            lines.append(f"{name}\t{_relative(package.path, root)}\t({package.build_type})")
        if lookup is not None and not (args.names_only or args.paths_only):
            for dep in _dependency_rows(package, loaded.packages, lookup):
                kinds = ",".join(dep["kinds"])  # type: ignore[arg-type]
                lines.append(f"  {dep['name']}\t{kinds}\t{dep['resolution']}")
    if lines:
        print("\n".join(lines), file=terminal.stdout)
    return 0


#: how `info` and `list --deps` name a key wsbuild answers itself (`wsbuild deps`'s words)
STOOD_IN = "stood in for by wsbuild"
DRIVEN = "written by wsbuild for the installed program"
NOT_INSTALLED = "not installed: wsbuild test counts its tests as skipped"


@dataclass(frozen=True, slots=True)
class Lookup:
    """How `info` and `list --deps` look dependencies up: as the build does (in the underlay's
    build environment), with the keys wsbuild answers itself named as `wsbuild deps` and the
    build name them."""

    resolver: Resolver
    #: key → (resolution, where) for the keys wsbuild answers itself
    by_wsbuild: Mapping[str, tuple[str, str]]


def _lookup(build_base: Path) -> Lookup:
    import sys

    from wsbuild.session import LINT_SHIM  # lazy: off `list` and `graph`
    from wsbuild.underlay.environment import prepare_underlay  # lazy: off `list` and `graph`
    from wsbuild.underlay.lint import LINTERS  # lazy: off `list` and `graph`
    from wsbuild.underlay.wheels import JAZZY_WHEELS  # lazy: off `list` and `graph`
    from wsbuild.workspace.resolve import Resolver  # lazy: off `list` and `graph`

    shim = build_base / LINT_SHIM
    underlay = prepare_underlay(os.environ, executable=sys.executable, repair=False,
                                shim_dir=shim, notice=lambda _text: None, dry_run=True)
    venv = underlay.venv
    resolver = Resolver.from_environment(underlay.environ, [venv] if venv else [], detailed=True)
    by_wsbuild = {module: (NOT_INSTALLED, "") for module in LINTERS.values()
                  if module not in JAZZY_WHEELS}
    by_wsbuild.update({name: (DRIVEN, str(shim)) for name in underlay.lint_driven})
    by_wsbuild.update({name: (STOOD_IN, str(shim)) for name in underlay.lint_stand_ins})
    return Lookup(resolver, by_wsbuild)


def _dependency_rows(package: Package, workspace: dict[str, Package],
                     lookup: Lookup) -> list[dict[str, object]]:
    from wsbuild.workspace.model import Resolution  # lazy: off `mixin list`
    from wsbuild.workspace.resolve import resolve_dependencies  # lazy: off `list` and `graph`

    rows: list[dict[str, object]] = []
    for dep in resolve_dependencies(package, workspace, lookup.resolver):
        resolution, location = dep.resolution.value, dep.location
        if dep.resolution is Resolution.UNRESOLVED and dep.name in lookup.by_wsbuild:
            resolution, location = lookup.by_wsbuild[dep.name]
        rows.append({"name": dep.name, "kinds": [k.value for k in dep.kinds],
                     "resolution": resolution, "location": location})
    return rows


#: how each dependency category's edges are drawn (by DepCategory value)
_STYLE = {"build": "solid", "run": "dashed", "test": "dotted"}
_MERMAID_ARROW = {"build": "-->", "run": "-.->", "test": "..->"}


def format_graph(graph: Graph, names: list[str], style: str) -> str:
    from wsbuild.workspace.graph import ALL_CATEGORIES  # lazy: off `mixin list` and Tab completion

    selected = set(names)
    edges = [
        (name, dep, category)
        for name in names
        for category in ALL_CATEGORIES
        for dep in sorted(graph.edges[name][category])
        if dep in selected
    ]
    if style == "dot":
        lines = ["digraph workspace {", "  rankdir=LR;", "  node [shape=box];"]
        lines += [f'  "{n}";' for n in names]
        lines += [
            f'  "{a}" -> "{b}" [style={_STYLE[c.value]}, label="{c.value}"];' for a, b, c in edges
        ]
        lines.append("}")
        return "\n".join(lines)
    if style == "mermaid":
        lines = ["flowchart LR"]
        lines += [f"  {n}" for n in names]
        lines += [f"  {a} {_MERMAID_ARROW[c.value]}|{c.value}| {b}" for a, b, c in edges]
        return "\n".join(lines)
    lines = []
    for name in names:
        lines.append(name)
        for category in ALL_CATEGORIES:
            deps = sorted(graph.edges[name][category] & selected)
            if deps:
                lines.append(f"  {category.value:<6} {', '.join(deps)}")
    return "\n".join(lines)


def run_graph(args: argparse.Namespace) -> int:
    """Print the dependency graph of the selected packages."""
    from wsbuild.verbs.load import load, load_request_from_args  # lazy: off `mixin list`

    terminal = terminal_from_args(args)
    loaded = load(load_request_from_args(args), warn=terminal.warnings, remember=True)
    _read_only(terminal, loaded)
    style = "dot" if args.dot else "mermaid" if args.mermaid else "text"
    text = format_graph(loaded.graph, loaded.selected, style)
    if text:
        print(text, file=terminal.stdout)
    return 0


def run_info(args: argparse.Namespace) -> int:
    """Describe packages in detail."""
    from wsbuild.verbs.load import load, load_request_from_args  # lazy: off `mixin list`

    terminal = terminal_from_args(args)
    loaded = load(load_request_from_args(args), warn=terminal.warnings, remember=True)
    _read_only(terminal, loaded)
    lookup = _lookup(loaded.workspace.build_base)
    blocks = []
    records: list[dict[str, object]] = []
    for name in args.package_names or loaded.selected:
        if name not in loaded.packages:
            import difflib

            close = difflib.get_close_matches(name, sorted(loaded.packages), n=3)
            raise SelectionError(
                f"no package named '{name}' in the workspace",
                hint=("did you mean " + ", ".join(f"'{c}'" for c in close) + "?") if close
                else "run 'wsbuild list -n' to see the package names",
            )
        package = loaded.packages[name]
        rows = _dependency_rows(package, loaded.packages, lookup)
        if getattr(args, "json", False):
            records.append({"name": name, "path": str(package.path),
                            "build_type": package.build_type, "version": package.version,
                            "dependencies": rows})
            continue
        lines = [
            f"{name}",
            f"  path:       {package.path}",
            f"  build type: {package.build_type}",
            f"  version:    {package.version}",
        ]
        if package.description:
            lines.append(f"  description: {package.description}")
        if package.member_of_groups:
            lines.append(f"  groups:     {', '.join(package.member_of_groups)}")
        if rows:
            lines.append("  dependencies:")
            width = max(len(str(r["name"])) for r in rows)
            for row in rows:
                kinds = ", ".join(k.replace("_depend", "") for k in row["kinds"])  # type: ignore[union-attr]
                where = f" ({row['location']})" if row["location"] else ""
                lines.append(f"    {str(row['name']):<{width}}  [{kinds}]  {row['resolution']}{where}")
        else:
            lines.append("  dependencies: none")
        blocks.append("\n".join(lines))
    if getattr(args, "json", False):
        print(json.dumps(records, indent=2), file=terminal.stdout)
        return 0
    print("\n\n".join(blocks), file=terminal.stdout)
    return 0
