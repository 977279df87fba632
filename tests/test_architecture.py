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


#: a node of the document's diagrams: `NAME["room/module.py<br/>what it holds"]`
NODE = re.compile(r'\["((?:[a-z_]+/)*[a-z_0-9]+\.py)<br/>(.*?)"\]')
#: a name the label claims the module has: `Class`, `Class.attribute`, `function`, `.attribute`
#: (of the class named last)
NAMED = re.compile(r"(?<![\w./])(\.?[A-Za-z_]\w*(?:\.\w+)?)")


def _defined(path: Path) -> dict[str, set[str]]:
    """Top-level names of a module (classes, functions, assignments, imports), each class with
    its annotated attributes, methods and properties."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names: dict[str, set[str]] = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            names[node.name] = {
                item.target.id if isinstance(item, ast.AnnAssign) else item.name  # type: ignore[union-attr]
                for item in node.body
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef))
                or (isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name))}
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            names[node.name] = set()
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for target in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                if isinstance(target, ast.Name):
                    names[target.id] = set()
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update({(a.asname or a.name).split(".")[0]: set() for a in node.names})
    return names


def diagram_claims(text: str) -> list[str]:
    """What the diagrams (the fenced blocks) claim of the code that is not so: each node's
    label names its module first, then code names (with a capital, an underscore or a dot)
    that the module must define — a class's attributes as `Class.attr, .attr`."""
    wrong: list[str] = []
    blocks = re.findall(r"^```\w*\n(.*?)^```", text, re.S | re.M)
    for block in blocks:
        for module, label in NODE.findall(block):
            path = PACKAGE / module
            if not path.is_file():
                wrong.append(f"{module}: no such module")
                continue
            defined = _defined(path)
            last_class = ""
            for word in NAMED.findall(label.replace("<br/>", " ").replace("&lt;", "<")):
                owner, _, attribute = word.partition(".")
                if not owner:  # `.attribute` of the class named last
                    owner = last_class
                elif not (owner[0].isupper() or "_" in owner or attribute):
                    continue  # a plain word of the label
                if owner not in defined:
                    wrong.append(f"{module}: names {owner}, which it does not define")
                    continue
                if owner[0].isupper() and owner in defined and defined[owner]:
                    last_class = owner
                if attribute and attribute not in defined[owner]:
                    wrong.append(f"{module}: names {owner}.{attribute}, which is no attribute")
    return wrong


def test_the_diagrams_name_only_what_the_code_has() -> None:
    """The fenced diagrams are claims too: each node's module exists and defines the classes,
    functions and attributes its label names (`BuildPlan`, `PackagePlan.steps`)."""
    text = DOC.read_text(encoding="utf-8")
    assert len(NODE.findall(text)) >= 10
    wrong = diagram_claims(text)
    assert not wrong, "docs/architecture.md's diagrams:\n" + "\n".join(wrong)


def test_the_diagram_check_finds_a_missing_attribute_and_class() -> None:
    text = ('```mermaid\nA["builder/plan.py<br/>BuildPlan: PackagePlan.steps, .wheels"]\n'
            'B["builder/plan.py<br/>Nowhere, make_plan"]\n```\n')
    assert diagram_claims(text) == [
        "builder/plan.py: names PackagePlan.wheels, which is no attribute",
        "builder/plan.py: names Nowhere, which it does not define",
    ]


def test_sessions_are_opened_by_the_build_and_the_test_run_only() -> None:
    """The document's "the session its run opened": `open_session` is called by
    builder/pipeline.py (a build, its dry run) and testing/test_run.py (a test run) only."""
    callers = sorted({str(path.relative_to(PACKAGE)) for path in PACKAGE.rglob("*.py")
                      for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
                      if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                      and node.func.id == "open_session"})
    assert callers == ["builder/pipeline.py", "testing/test_run.py"]


#: names retired by issue 38 (one meaning per word, docs/architecture.md's glossary): a module,
#: class or function by an old name, or a word that meant several things
RETIRED: dict[str, str] = {
    r"(?<!\w)runners\.py": "testing/test_run.py (the test run); a runner is a TestRunner",
    r"(?<![\w/])report\.(?:py|print_|Reporter)": "reporter.py (the one reporter)",
    r"\bBuildContext\b": "PackageContext (build_types/__init__.py: package_context)",
    r"\brebuild_reason\b": "record/dirty.py: dirty_reason (the one dirty check)",
    r"\bforget_state\b": "nothing: a CMake package's steps forget its configure record",
    r"\bclear_directory\b": "nothing (dead code)",
    r"\bEnvironmentFailure\b": "nothing (dead code)",
    r"\bTestTool\b": "BuildType.test_runner",
    r"\breplay_recorder\b": "the recorder handed down: cli.main(recorder=), Terminal.recorder",
    r"\bexternal_inputs\b": "BuildType.outside_reads (a record's outside reads are no inputs)",
    r"\bcmake_inputs\b": "build_types/cmake_reads.py (what a CMake build read)",
    r"(?<![\w.])Runner\b": "CommandRunner (runs a step's command); a runner is a TestRunner",
}


def retired_names(files: list[Path]) -> list[str]:
    found = []
    for path in files:
        text = path.read_text(encoding="utf-8")
        where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path.name
        for pattern, instead in RETIRED.items():
            for match in re.finditer(pattern, text):
                line = text.count("\n", 0, match.start()) + 1
                found.append(f"{where}:{line}: {match.group(0)} → {instead}")
    return found


def test_no_retired_name_is_left_in_code_tests_or_docs() -> None:
    files = [p for p in [*PACKAGE.rglob("*.py"), *(ROOT / "tests").rglob("*.py"),
                         *(ROOT / "benchmarks").rglob("*.py"), *(ROOT / "docs").rglob("*.md"),
                         ROOT / "README.md"]
             if p != Path(__file__).resolve()]
    found = retired_names(files)
    assert not found, "\n".join(found)


def test_the_retired_name_check_finds_an_old_name(tmp_path: Path) -> None:
    old = tmp_path / "old.md"
    old.write_text("see testing/runners.py\nand the BuildContext, not test_runners.py\n")
    assert retired_names([old]) == [
        "old.md:1: runners.py → testing/test_run.py (the test run); a runner is a TestRunner",
        "old.md:2: BuildContext → PackageContext (build_types/__init__.py: package_context)"]


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


def _kept_patterns() -> list[re.Pattern[str]]:
    """The first column of the table of the files wsbuild keeps, as regular expressions."""
    section = DOC.read_text().split("## Every file wsbuild keeps for itself", 1)[1]
    section = section.split("\n## ", 1)[0]
    patterns = []
    for line in section.splitlines():
        if not line.startswith("| `"):
            continue
        for shown in re.findall(r"`([^`]+)`", line.split(" | ")[0]):
            if "/" not in shown and not shown.startswith("observe-test"):
                continue
            shown = shown if not shown.startswith("observe-test") else \
                "build/<pkg>/.wsbuild/" + shown
            text = re.escape(shown).replace(r"\*\*", ".*").replace(r"\*", "[^/]*")
            text = text.replace("<pkg>", "[^/]+").replace("<run>", "[^/]+")
            patterns.append(re.compile(text + "$"))
    return patterns


def test_every_file_wsbuild_keeps_is_in_the_table(built: Path) -> None:
    """A built, tested and listed workspace (a CMake and two Python packages), and wsbuild's
    cache: each file wsbuild wrote for itself matches a row of the table."""
    import os

    from conftest import run_wsbuild
    from wsbuild.files import wsbuild_cache_dir

    assert run_wsbuild("test", cwd=built).returncode == 0
    assert run_wsbuild("list", cwd=built).returncode == 0
    found = ["build/.built_by", "build/.wsbuild.build.lock"]
    for root, _dirs, files in os.walk(built):
        rel = Path(root).relative_to(built)
        parts = rel.parts
        own = parts[:1] == ("log",) or (len(parts) >= 2 and parts[0] == "build" and (
            parts[1] == ".wsbuild" or (len(parts) >= 3 and parts[2] == ".wsbuild")))
        if own:
            found += [str(rel / name) for name in files]
    found += [str(Path("log") / entry.name) for entry in os.scandir(built / "log")
              if not entry.is_dir(follow_symlinks=False)]
    found += [f"{base}/COLCON_IGNORE" for base in ("build", "install")
              if (built / base / "COLCON_IGNORE").exists()]
    cache = wsbuild_cache_dir(os.environ)
    for root, _dirs, files in os.walk(cache):
        found += ["<cache>/" + str(Path(root, name).relative_to(cache)) for name in files]
    patterns = _kept_patterns()
    assert len(patterns) > 20
    missing = sorted({path for path in found if not any(p.match(path) for p in patterns)})
    assert not missing, "files wsbuild keeps that the table of docs/architecture.md lacks: " \
        + ", ".join(missing[:20])
