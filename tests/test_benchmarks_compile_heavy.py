"""The compile-heavy benchmark workspace: interface packages in a chain of depth 3 with fan-out,
10-20 interfaces each, C++ users; `wsbuild list` reads the edges the generator planned."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from conftest import REPO, run_wsbuild

sys.path.insert(0, str(REPO))

from benchmarks.compile_heavy import (  # noqa: E402
    DEEPEST,
    CompileHeavySpec,
    dependents_of,
    edited_message,
    generate_compile_heavy,
)


def _depth(name: str, edges: dict[str, list[str]]) -> int:
    deps = edges[name]
    return 0 if not deps else 1 + max(_depth(d, edges) for d in deps)


def test_interface_chain_fan_out_and_cpp_users(tmp_path: Path) -> None:
    ws = generate_compile_heavy(tmp_path / "ws")
    result = run_wsbuild("list", "--json", "--deps", cwd=ws.root)
    assert result.returncode == 0, result.stderr
    rows = json.loads(result.stdout)
    edges = {row["name"]: sorted(d["name"] for d in row["dependencies"]
                                 if d["resolution"] == "workspace") for row in rows}
    assert {(n, d) for n, deps in edges.items() for d in deps} == ws.edges()
    interfaces = [n for n in edges if n.endswith("_msgs")]
    assert len(interfaces) >= 6
    for name in interfaces:
        base = ws.root / ws.by_name(name).path
        files = [p for kind in ("msg", "srv", "action") for p in (base / kind).glob(f"*.{kind}")]
        assert 10 <= len(files) <= 20, name
        listed = (base / "CMakeLists.txt").read_text()
        assert all(f'"{p.parent.name}/{p.name}"' in listed for p in files)
    kinds = {p.suffix for n in interfaces for p in (ws.root / ws.by_name(n).path).rglob("*.*")}
    assert {".msg", ".srv", ".action"} <= kinds
    # a chain of depth 3 above the base package, with fan-out (some package has two users)
    assert max(_depth(n, {k: [d for d in v if d in interfaces] for k, v in edges.items()
                          if k in interfaces}) for n in interfaces) == 3
    users = {d: [n for n in interfaces if d in edges[n]] for d in interfaces}
    assert max(len(u) for u in users.values()) >= 2
    libraries = [n for n in edges if n not in interfaces]
    assert len(libraries) >= 3
    assert any(d in libraries for n in libraries for d in edges[n]), "a library with users"
    assert any(d in interfaces for n in libraries for d in edges[n]), "C++ using messages"
    assert DEEPEST in interfaces and edited_message(ws.root).is_file()
    assert dependents_of(DEEPEST, ws) == sorted({DEEPEST, *(n for n in edges if DEEPEST in edges[n])})


def test_same_spec_same_bytes(tmp_path: Path) -> None:
    first = generate_compile_heavy(tmp_path / "a", CompileHeavySpec(interfaces=12))
    second = generate_compile_heavy(tmp_path / "b", CompileHeavySpec(interfaces=12))
    files = sorted(p.relative_to(first.root) for p in first.root.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(second.root) for p in second.root.rglob("*")
                           if p.is_file())
    assert all((first.root / f).read_bytes() == (second.root / f).read_bytes() for f in files)
