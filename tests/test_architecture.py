"""docs/architecture.md says only what a test checks: each of its claims is a list item that
names the test holding it (`tests/test_x.py::test_name`), and each named test exists. Also the
claims no other test holds: the library never prints."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "wsbuild"
DOC = ROOT / "docs" / "architecture.md"

#: `tests/test_x.py::test_name` (a parametrised test is named without its parameters)
CITED = re.compile(r"`(tests/[\w/]+\.py)::(\w+)`")


def claims(text: str) -> list[str]:
    """The document's list items, each with its continuation lines, outside code blocks."""
    items: list[str] = []
    fenced = False
    for line in text.splitlines():
        if line.startswith("```"):
            fenced = not fenced
            continue
        if fenced:
            continue
        if line.startswith("- "):
            items.append(line)
        elif items and line.startswith("  ") and line.strip():
            items[-1] += " " + line.strip()
        elif not line.strip() or not line.startswith("  "):
            if items and not items[-1].endswith("\0"):
                items[-1] += "\0"
    return [item.rstrip("\0") for item in items]


def defined_tests(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return {node.name for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))}


def test_every_claim_of_the_architecture_document_names_a_test() -> None:
    uncited = [item[:100] for item in claims(DOC.read_text(encoding="utf-8"))
               if not CITED.search(item)]
    assert not uncited, "name the test that checks each claim, or remove it:\n" + "\n".join(uncited)


def test_the_tests_the_architecture_document_names_exist() -> None:
    text = DOC.read_text(encoding="utf-8")
    cited = CITED.findall(text)
    assert len(cited) >= 20  # the document is made of checked claims
    missing = [f"{file}::{name}" for file, name in sorted(set(cited))
               if not (ROOT / file).is_file() or name not in defined_tests(ROOT / file)]
    assert not missing, "docs/architecture.md names tests that do not exist:\n" + "\n".join(missing)


def test_the_claim_check_finds_an_uncited_item() -> None:
    text = ("intro\n\n- a claim checked by `tests/test_a.py::test_b`\n- a claim\n  continued"
            " without a test\n\n```\n- code\n```\n")
    items = claims(text)
    assert items == ["- a claim checked by `tests/test_a.py::test_b`",
                     "- a claim continued without a test"]
    assert [bool(CITED.search(item)) for item in items] == [True, False]


#: modules that are the main of a child process wsbuild starts: their output is that
#: process's, read by the parent
CHILD_MAINS = {"wsbuild/build_types/pybuild/by_hand.py", "wsbuild/build_types/pybuild/pep517_hook.py",
               "wsbuild/build_types/pybuild/setup_py_helper.py"}
#: where output to the user is made: the shell, the verbs, the one reporter; and the replay of an
#: unchanged command, which keeps a copy of what the run wrote (recording.py) and writes it again
#: (replay.py)
PRINTERS = ("wsbuild/cli.py", "wsbuild/launch.py", "wsbuild/reporter.py", "wsbuild/verbs/",
            "wsbuild/engine/recording.py", "wsbuild/engine/replay.py")


def prints(path: Path) -> list[int]:
    """Lines of `path` that print or write to sys.stdout / sys.stderr."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                and node.func.id == "print":
            found.append(node.lineno)
        elif isinstance(node, ast.Attribute) and node.attr in ("stdout", "stderr") \
                and isinstance(node.value, ast.Name) and node.value.id == "sys":
            found.append(node.lineno)
    return found


def test_the_library_never_prints() -> None:
    """Below the verbs, work emits events or returns text; only the shell, the verbs and the
    reporter write to the terminal."""
    found = [f"{path.relative_to(ROOT)}:{line}"
             for path in sorted(PACKAGE.rglob("*.py"))
             if not str(path.relative_to(ROOT)).startswith(PRINTERS)
             and str(path.relative_to(ROOT)) not in CHILD_MAINS
             for line in prints(path)]
    assert not found, "emit an event (wsbuild/events.py) instead:\n" + "\n".join(found)


def test_the_print_check_finds_a_print_and_a_stream(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text("import sys\ndef f():\n    print('x')\n    sys.stderr.write('y')\n")
    assert prints(module) == [3, 4]
