"""The rooms of wsbuild/ import downward only (docs/architecture.md draws the same rooms)."""

from __future__ import annotations

import ast
import os
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "wsbuild"

#: rank of each room: a module may import from its own rank or a lower one
RANKS: dict[str, int] = {
    "errors": 0, "files": 0, "words": 0, "substitution": 0, "inputs": 0, "signature": 0, "redaction": 0,
    "terminal": 0, "dataclass_code": 0, "hashes": 0, "patterns": 0,
    "engine": 1, "workspace": 1, "events": 1, "record": 1, "observe": 1,
    "build_types": 2, "prefix": 2, "underlay": 2, "cache": 2,
    "session": 3, "deps": 3,
    "builder": 4, "testing": 4, "create": 4, "runreport": 4,
    "verbs": 5, "reporter": 5,
    "cli": 6, "__init__": 6,
    "launch": 7,
    "__main__": 8,
}

#: the only imports between different rooms of one rank (from room, to room), each for a reason
SIDEWAYS: dict[tuple[str, str], str] = {
    ("dataclass_code", "hashes"): "a method's source is known by its digest, with the hash "
                                  "taken without loading OpenSSL",
    ("dataclass_code", "files"): "the kept code is written as wsbuild writes every file it "
                                 "keeps (atomically)",
    ("redaction", "patterns"): "its patterns are compiled when a text is first redacted",
    ("terminal", "patterns"): "its pattern is compiled when a replay first compares a terminal",
    ("events", "engine"): "the job events are the engine's; events.py adds the run's own",
    ("build_types", "prefix"): "a build type stages into a prefix and names its hooks",
    ("cache", "prefix"): "a restore commits into install/ exactly as a build commits its stage",
    ("builder", "runreport"): "every build writes its run report",
    ("testing", "runreport"): "a test run runs its jobs and writes its report as a build does",
    ("verbs", "reporter"): "a verb hands the one reporter to the work it starts",
    ("files", "inputs"): "a write that compares with what is there reads it as a declared input",
    ("inputs", "signature"): "a declared input is compared by the one stat signature",
    ("record", "observe"): "a record holds what the steps were observed to read",
    ("engine", "record"): "a command's recording asks of its environment what a record asks",
}


def room_of(module: str) -> str:
    """`wsbuild.builder.pipeline` -> `build`; `wsbuild.cli` -> `cli`."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def modules() -> list[tuple[str, Path]]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        found.append((".".join(rel.parts), path))
    return found


def imported(path: Path, module: str) -> list[tuple[int, str]]:
    """(line, module) of every wsbuild import in `path`, function-level imports included."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    result: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            if node.level:
                base = module.split(".")[: -node.level]
                target = ".".join([*base, node.module])
            else:
                target = node.module
            if target == "wsbuild":
                result += [(node.lineno, f"wsbuild.{alias.name}") for alias in node.names]
            elif target.startswith("wsbuild."):
                # `from wsbuild.builder.shards import run`: the module imported is shards.run
                package = PACKAGE.parent.joinpath(*target.split("."))
                submodules = [f"{target}.{alias.name}" for alias in node.names
                              if (package / f"{alias.name}.py").is_file()
                              or (package / alias.name / "__init__.py").is_file()]
                result += [(node.lineno, t) for t in submodules or [target]]
        elif isinstance(node, ast.Import):
            result += [(node.lineno, a.name) for a in node.names if a.name.startswith("wsbuild.")]
    return result


def test_every_room_has_a_rank() -> None:
    rooms = {room_of(name) for name, _ in modules()}
    assert rooms - {"templates"} <= set(RANKS), f"rooms without a rank: {sorted(rooms - set(RANKS))}"


def test_rooms_describe_themselves() -> None:
    for init in sorted(PACKAGE.glob("*/__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8")))
        assert doc, f"{init} has no docstring saying what the room is for"


@pytest.mark.parametrize("name,path", modules(), ids=lambda v: v if isinstance(v, str) else "")
def test_imports_point_downward(name: str, path: Path) -> None:
    own = RANKS[room_of(name)]
    upward = [
        f"{path.relative_to(PACKAGE.parent)}:{line} imports {target} (rank {RANKS[room_of(target)]} > {own})"
        for line, target in imported(path, name)
        if RANKS.get(room_of(target), 0) > own
    ]
    assert not upward, "\n".join(upward)


@pytest.mark.parametrize("name,path", modules(), ids=lambda v: v if isinstance(v, str) else "")
def test_no_sideways_imports_but_the_listed(name: str, path: Path) -> None:
    own_room = room_of(name)
    sideways = [
        f"{path.relative_to(PACKAGE.parent)}:{line} imports {target} ({own_room} → "
        f"{room_of(target)}, both rank {RANKS[own_room]}): list it in SIDEWAYS with a reason, "
        "or move the code"
        for line, target in imported(path, name)
        if room_of(target) != own_room and RANKS.get(room_of(target)) == RANKS[own_room]
        and (own_room, room_of(target)) not in SIDEWAYS
    ]
    assert not sideways, "\n".join(sideways)


#: builder/'s own rooms (issue 45) that import nothing else of builder/: a run's resources and
#: the suite's oracle stand under the plan and the build that use them
BUILDER_FLOOR = ("wsbuild.builder.resources", "wsbuild.builder.oracles")


def _builder_imports() -> dict[str, set[str]]:
    """builder/'s modules and the builder/ modules each imports (TYPE_CHECKING and
    function-level imports included)."""
    graph: dict[str, set[str]] = {}
    for name, path in modules():
        if name.startswith("wsbuild.builder."):
            graph[name] = {target for _, target in imported(path, name)
                           if target.startswith("wsbuild.builder.") and target != name}
    return graph


def test_builders_resources_and_oracles_import_nothing_else_of_builder() -> None:
    upward = [f"{name} imports {target}" for name, targets in _builder_imports().items()
              if name.startswith(BUILDER_FLOOR) for target in sorted(targets)
              if not target.startswith(BUILDER_FLOOR)]
    assert not upward, "\n".join(upward)


def test_no_import_circle_among_builders_modules() -> None:
    """One module of builder/ never reaches itself through the modules it imports (a type
    named only for annotations counts): each can be read knowing only those below it."""
    graph = _builder_imports()
    circles: list[list[str]] = []

    def visit(name: str, path: list[str], done: set[str]) -> None:
        if name in path:
            circles.append(path[path.index(name):] + [name])
            return
        if name in done:
            return
        done.add(name)
        for target in sorted(graph.get(name, ())):
            visit(target, [*path, name], done)

    for start in sorted(graph):
        visit(start, [], set())
    shown = sorted({" -> ".join(c) for c in circles})
    assert not shown, "\n".join(shown)


def test_every_room_ships_in_the_wheel() -> None:
    """pyproject.toml lists the packages explicitly (templates/ is mapped in): a new room must be
    added there, or a non-editable install lacks it."""
    import tomllib

    listed = set(tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    on_disk = {".".join(init.parent.relative_to(PACKAGE.parent).parts) for init in PACKAGE.rglob("__init__.py")}
    assert on_disk - listed == set(), f"add to [tool.setuptools] packages: {sorted(on_disk - listed)}"


#: the only modules that may parse command lines: the shell and the verbs (each owns its options)
ARGPARSE_ALLOWED = ("wsbuild.cli", "wsbuild.verbs.")


def imports_module(path: Path, name: str) -> list[int]:
    """Lines of `path` that import the standard module `name` (also inside functions)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import) and any(a.name.split(".")[0] == name for a in node.names):
            lines.append(node.lineno)
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module \
                and node.module.split(".")[0] == name:
            lines.append(node.lineno)
    return lines


def test_argparse_only_in_the_shell_and_the_verbs() -> None:
    found = [
        f"{path.relative_to(PACKAGE.parent)}:{line} imports argparse"
        for name, path in modules()
        if not (name == ARGPARSE_ALLOWED[0] or name.startswith(ARGPARSE_ALLOWED[1]))
        for line in imports_module(path, "argparse")
    ]
    assert not found, "command-line parsing belongs in cli.py or verbs/:\n" + "\n".join(found)


def test_the_argparse_check_sees_function_level_imports(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from argparse import Namespace\n    import argparse.x\n")
    assert imports_module(module, "argparse") == [2, 3]


def test_the_architecture_document_tells_the_ranks_the_test_holds() -> None:
    """docs/architecture.md's table lists each room at the rank RANKS gives it."""
    import re

    doc = (PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    documented: dict[str, int] = {}
    for line in doc.splitlines():
        row = re.match(r"^\|\s*(\d+)\s*\|(.*?)\|", line)
        if row:
            for room in re.findall(r"`([a-z_]+)(?:/|\.py)`", row.group(2)):
                documented[room] = int(row.group(1))
    rooms = {room_of(name) for name, _ in modules()} - {"__init__"}
    assert {room: documented.get(room) for room in sorted(rooms)} == \
        {room: RANKS[room] for room in sorted(rooms)}



def test_no_room_is_named_build() -> None:
    """Linters and the standard Python .gitignore skip folders named `build`."""
    assert not (PACKAGE / "build").exists()


#: limits past which a module or function says why in its docstring
MODULE_LINES, FUNCTION_LINES = 500, 80


def oversized(path: Path) -> list[str]:
    """Modules over MODULE_LINES and functions over FUNCTION_LINES whose docstring does not
    start a sentence with "Over 500 lines because" / "Over 80 lines because"."""
    text = path.read_text(encoding="utf-8")
    tree = ast.parse(text)
    found = []
    if len(text.splitlines()) > MODULE_LINES and \
            f"Over {MODULE_LINES} lines because" not in (ast.get_docstring(tree) or ""):
        found.append(f"{path.name}: {len(text.splitlines())} lines")
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            length = (node.end_lineno or node.lineno) - node.lineno + 1
            reason = f"Over {FUNCTION_LINES} lines because" in (ast.get_docstring(node) or "")
            if length > FUNCTION_LINES and not reason:
                found.append(f"{path.name}:{node.lineno} {node.name}: {length} lines")
    return found


def test_modules_and_functions_stay_small_or_say_why() -> None:
    found = [item for path in sorted(PACKAGE.rglob("*.py")) for item in oversized(path)]
    assert not found, "split these, or say why in the docstring:\n" + "\n".join(found)


def test_the_size_check_finds_a_long_function(tmp_path: Path) -> None:
    body = "\n".join(f"    x{i} = {i}" for i in range(FUNCTION_LINES))
    module = tmp_path / "m.py"
    module.write_text(f'"""m."""\n\n\ndef long():\n    """Long."""\n{body}\n')
    assert oversized(module) == [f"m.py:4 long: {FUNCTION_LINES + 2} lines"]
    module.write_text(f'"""m."""\n\n\ndef long():\n    """Over 80 lines because.""" \n{body}\n')
    assert oversized(module) == []


#: why a function, rather than its module's top, imports a wsbuild module: measured to keep it
#: off a path that does not need it (`# lazy: <that path>`), or an import circle at the top
#: (`# circle: <the module it would import back>`)
IMPORT_REASONS = ("# lazy: ", "# circle: ")


def untagged_imports(path: Path) -> list[int]:
    """Lines of the imports of a wsbuild module inside a function of `path` whose line (a
    parenthesised import's last line) gives none of IMPORT_REASONS."""
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    found: set[int] = set()
    for function in ast.walk(ast.parse(text)):
        if not isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(function):
            if isinstance(node, ast.ImportFrom):
                internal = bool(node.level) or (node.module or "").split(".")[0] == "wsbuild"
            elif isinstance(node, ast.Import):
                internal = any(alias.name.split(".")[0] == "wsbuild" for alias in node.names)
            else:
                continue
            last = lines[(node.end_lineno or node.lineno) - 1]
            if internal and not any(reason in last for reason in IMPORT_REASONS):
                found.add(node.lineno)
    return sorted(found)


def test_function_level_imports_of_wsbuild_say_why() -> None:
    found = [f"{path.relative_to(PACKAGE.parent)}:{line}"
             for path in sorted(PACKAGE.rglob("*.py")) for line in untagged_imports(path)]
    assert not found, ("import these at the module's top, or say why (# lazy: <the path it "
                       "keeps the module off> / # circle: <the module it would import back>):\n"
                       + "\n".join(found))


def test_the_import_check_finds_an_untagged_function_level_import(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text(
        "from wsbuild.errors import WsbuildError\n\n\n"
        "def f():\n"
        "    import json\n"
        "    from wsbuild.files import atomic_write\n"
        "    from wsbuild.words import (\n"
        "        plural)  # lazy: off the replayed no-op\n"
        "    from wsbuild.cli import (  # lazy: said on the first line only\n"
        "        main)\n"
        "    import wsbuild.engine.replay  # circle: wsbuild.engine.replay\n"
        "\n"
        "    def g():\n"
        "        import wsbuild.reporter\n")
    assert untagged_imports(module) == [6, 9, 14]


def test_the_modules_the_docs_and_docstrings_name_exist() -> None:
    """A path like `builder/pipeline.py` in docs/architecture.md, README.md or a docstring
    names a module that is there (a renamed module leaves no stale name behind)."""
    pattern = re.compile(r"\b((?:[a-z_]+/)+[a-z_0-9]+\.py)\b")
    repo = PACKAGE.parent
    texts = [(path, path.read_text()) for path in sorted(PACKAGE.rglob("*.py"))]
    texts += [(repo / name, (repo / name).read_text()) for name in ("README.md",
                                                                   "docs/architecture.md")]
    missing = sorted({f"{path.relative_to(repo)}: {name}" for path, text in texts
                      for name in pattern.findall(text)
                      if not any(base.joinpath(name).exists()
                                 for base in (repo, PACKAGE, repo / "tests"))})
    assert not missing, "\n".join(missing)


def test_as_root_a_skip_for_mounting_fails_the_run() -> None:
    """The full-disk and read-only-install tests skip where no mount is allowed; CI runs as
    root, where they can mount: there that skip is not on the allow-list."""
    from conftest import ALLOWED_SKIPS

    mount_skip = "this machine lets tests mount nothing"
    assert (mount_skip in ALLOWED_SKIPS) == (os.geteuid() != 0)
