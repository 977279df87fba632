"""The verb boundary: argparse's namespace is turned into frozen requests once, at each verb's
entry (the function cli.py runs) by the `*_from_args` converters; nothing below sees it. Each
option is declared by the module that uses it, and verbs/ has no import cycle."""

from __future__ import annotations

import argparse
import ast
from pathlib import Path

from test_layering import PACKAGE, imported, modules

#: functions cli.py calls with the namespace while it is being made (defaults files, mixins,
#: colcon's options before the verb, the notes of options without effect, Tab completion):
#: the parser's stage, before any verb runs
PARSE_STAGE = {
    ("wsbuild.verbs.defaults", "parse_with_defaults"),
    ("wsbuild.verbs.mixin", "apply_mixins"),
    ("wsbuild.verbs.mixin", "_apply"),
    ("wsbuild.verbs.colcon", "apply_global_arguments"),
    ("wsbuild.verbs.colcon", "ignored_notes"),
    ("wsbuild.verbs.completion", "_package_completer"),
    ("wsbuild.verbs.completion", "_executable_completer"),
    ("wsbuild.verbs.completion", "_mixin_completer"),
}


def verb_entries() -> set[tuple[str, str]]:
    """(module, function) of every verb's entry, as cli.py's parsers name them (`func`)."""
    from wsbuild.cli import build_parser

    found: set[tuple[str, str]] = set()

    def walk(parser: argparse.ArgumentParser) -> None:
        func = parser._defaults.get("func")  # no public way to read a parser's defaults
        if func:
            module, _, name = func.partition(":")
            found.add((module, name))
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in action.choices.values():
                    walk(sub)

    walk(build_parser())
    return found


def _namespace_parameters(function: ast.FunctionDef) -> set[str]:
    every = [*function.args.posonlyargs, *function.args.args, *function.args.kwonlyargs]
    return {a.arg for a in every
            if a.annotation is not None and "Namespace" in ast.unparse(a.annotation)}


def _held(function: ast.FunctionDef, boundary: bool) -> set[str]:
    """The names that hold the namespace in `function`, followed by data flow: its annotated
    parameters (an entry's first parameter with or without annotation), and every name
    assigned from one of them."""
    held = _namespace_parameters(function)
    every = [*function.args.posonlyargs, *function.args.args]
    if boundary and every:
        held.add(every[0].arg)
    changed = bool(held)
    while changed:
        changed = False
        for node in ast.walk(function):
            value = node.value if isinstance(node, (ast.Assign, ast.AnnAssign,
                                                    ast.NamedExpr)) else None
            if not (isinstance(value, ast.Name) and value.id in held):
                continue
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                if isinstance(target, ast.Name) and target.id not in held:
                    held.add(target.id)
                    changed = True
    return held


def _called_name(call: ast.Call) -> str:
    func = call.func
    return func.attr if isinstance(func, ast.Attribute) else \
        func.id if isinstance(func, ast.Name) else ""


def boundary_violations(module: str, path: Path, entries: set[tuple[str, str]]) -> list[str]:
    """Where `path` lets the namespace below the verb boundary: a function taking one that is
    no entry, converter or parser stage; a namespace handed to anything but a converter (or
    read with getattr outside those); a converter called below the boundary."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: list[str] = []
    where = str(path.relative_to(PACKAGE.parent) if path.is_relative_to(PACKAGE.parent)
                else path.name)
    for node in ast.walk(tree):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        name = node.name
        boundary = (module, name) in entries or name.endswith("_from_args")
        parse_stage = (module, name) in PARSE_STAGE
        held = _held(node, boundary)  # type: ignore[arg-type]
        if _namespace_parameters(node) and not (boundary or parse_stage):  # type: ignore[arg-type]
            found.append(f"{where}:{node.lineno} {name}() takes argparse's namespace below the "
                         "verb boundary: take a request instead")
        for call in (n for n in ast.walk(node) if isinstance(n, ast.Call)):
            called = _called_name(call)
            if called.endswith("_from_args") and not boundary and module != "wsbuild.cli":
                found.append(f"{where}:{call.lineno} {name}() calls {called}: the namespace is "
                             "converted at the verb's entry only")
            reads = called == "getattr" and call.args and isinstance(call.args[0], ast.Name) \
                and call.args[0].id in ("args", "parsed_args")
            if reads and not (boundary or parse_stage):
                found.append(f"{where}:{call.lineno} {name}() reads options with getattr below "
                             "the verb boundary")
            if parse_stage or not held:
                continue
            handed = [a for a in [*call.args, *(k.value for k in call.keywords)]
                      if isinstance(a, ast.Name) and a.id in held]
            if not handed:
                continue
            if called == "getattr":
                continue  # reading an option where the namespace is held
            if not called.endswith("_from_args"):
                found.append(f"{where}:{call.lineno} {name}() hands the namespace to "
                             f"{called or 'a call'}(): hand it a request")
    return found


def test_nothing_below_a_verbs_entry_sees_the_namespace() -> None:
    entries = verb_entries()
    assert ("wsbuild.verbs.build", "run_build_verb") in entries
    found = [item for name, path in modules() if name != "wsbuild.cli"
             for item in boundary_violations(name, path, entries)]
    assert not found, "\n".join(found)


def test_the_boundary_check_finds_a_namespace_below_it(tmp_path: Path) -> None:
    module = tmp_path / "probe.py"
    module.write_text(
        "import argparse\n"
        "def run_probe(args: argparse.Namespace) -> int:\n"
        "    helper(args)\n"
        "    return work(probe_from_args(args))\n"
        "def probe_from_args(args: argparse.Namespace) -> int:\n"
        "    return getattr(args, 'x', 0)\n"
        "def helper(args: argparse.Namespace) -> None:\n"
        "    probe_from_args(args)\n"
        "def work(request: int) -> int:\n"
        "    return request\n"
        "def unannotated(args) -> bool:\n"
        "    return getattr(args, 'y', False)\n"
        "def run_other(parsed):\n"
        "    options = parsed\n"
        "    return unannotated(args=options)\n")
    found = boundary_violations("wsbuild.verbs.probe", module,
                                {("wsbuild.verbs.probe", "run_probe"),
                                 ("wsbuild.verbs.probe", "run_other")})
    assert [line.split(" ", 1)[1] for line in found] == [
        "run_probe() hands the namespace to helper(): hand it a request",
        "helper() takes argparse's namespace below the verb boundary: take a request instead",
        "helper() calls probe_from_args: the namespace is converted at the verb's entry only",
        "unannotated() reads options with getattr below the verb boundary",
        "run_other() hands the namespace to unannotated(): hand it a request",
    ]


def test_the_verbs_import_no_cycle() -> None:
    """verbs/ (and cli.py) import each other without a cycle, function-level imports counted
    (an option shared by verbs lives in arguments.py, which imports no other verb module)."""
    graph: dict[str, set[str]] = {}
    for name, path in modules():
        if name.startswith("wsbuild.verbs.") or name == "wsbuild.cli":
            graph[name] = {target for _, target in imported(path, name)
                           if target.startswith("wsbuild.verbs.") or target == "wsbuild.cli"}
    cycles: list[str] = []
    state: dict[str, int] = {}  # 1: on the path, 2: done

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for target in sorted(graph.get(node, ())):
            if state.get(target) == 1:
                cycles.append(" → ".join([*path[path.index(target):], target]))
            elif target in graph and target not in state:
                visit(target, [*path, target])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert not cycles, "\n".join(cycles)
