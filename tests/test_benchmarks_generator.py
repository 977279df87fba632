"""The benchmark's workspace generator: what it writes is a workspace `wsbuild list` reads as planned."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from conftest import REPO, run_wsbuild

sys.path.insert(0, str(REPO))

from benchmarks.generate import WorkspaceSpec, generate_workspace, plan_packages  # noqa: E402


def test_wsbuild_lists_generated_packages_and_edges(tmp_path: Path) -> None:
    spec = WorkspaceSpec(python_packages=12, cmake_packages=3, seed=7, folder_size=2)
    ws = generate_workspace(tmp_path / "ws", spec)
    assert ws.edges(), "the seeded DAG has edges"

    result = run_wsbuild("list", "--json", "--deps", cwd=ws.root)
    assert result.returncode == 0, result.stderr
    rows = json.loads(result.stdout)
    assert len(rows) == 15
    types = {row["name"]: row["build_type"] for row in rows}
    assert sorted(types.values()).count("ament_cmake") == 3
    assert {row["name"]: row["path"] for row in rows} == {
        p.name: str(p.path) for p in ws.packages}
    # nested: src/<stack>/<part>/<pkg>
    assert all(len(Path(row["path"]).parts) == 4 for row in rows)
    listed_edges = {(row["name"], dep["name"]) for row in rows for dep in row["dependencies"]
                    if dep["resolution"] == "workspace"}
    assert listed_edges == ws.edges()
    # ament_cmake packages only build on other ament_cmake packages
    assert all(types[dep] == "ament_cmake" for name, dep in ws.edges()
               if types[name] == "ament_cmake")


def test_same_seed_same_workspace_other_seed_other_graph(tmp_path: Path) -> None:
    spec = WorkspaceSpec(python_packages=30, cmake_packages=2, seed=3)
    first = generate_workspace(tmp_path / "a", spec)
    second = generate_workspace(tmp_path / "b", spec)
    files = sorted(p.relative_to(first.root) for p in first.root.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(second.root) for p in second.root.rglob("*") if p.is_file())
    assert all((first.root / f).read_bytes() == (second.root / f).read_bytes() for f in files)
    other = plan_packages(WorkspaceSpec(python_packages=30, cmake_packages=2, seed=4))
    assert {(p.name, d) for p in other for d in p.depends} != first.edges()


def test_python_package_is_what_ros2_pkg_create_makes(tmp_path: Path) -> None:
    ws = generate_workspace(tmp_path / "ws", WorkspaceSpec(python_packages=2, seed=1))
    leaf = ws.leaves()[-1]
    base = ws.root / ws.by_name(leaf).path
    assert f"install_scripts=$base/lib/{leaf}" in (base / "setup.cfg").read_text()
    assert (base / "resource" / leaf).is_file()
    setup_py = (base / "setup.py").read_text()
    assert "('share/' + package_name, ['package.xml'])" in setup_py
    assert f"'node = {leaf}.node:main'" in setup_py
    assert ws.module_of(leaf).is_file()


def test_each_benchmark_replaces_only_its_own_section_of_the_report(tmp_path: Path) -> None:
    from benchmarks.tools import write_section

    docs = tmp_path / "benchmarks.md"
    docs.write_text("# report\n\nnotes kept\n")
    write_section(docs, "<!-- a -->", "<!-- /a -->", "<!-- a -->\nfirst\n<!-- /a -->\n")
    write_section(docs, "<!-- b -->", "<!-- /b -->", "<!-- b -->\nother\n<!-- /b -->\n")
    write_section(docs, "<!-- a -->", "<!-- /a -->", "<!-- a -->\nsecond\n<!-- /a -->\n")
    assert docs.read_text() == ("# report\n\nnotes kept\n\n<!-- a -->\nsecond\n<!-- /a -->\n\n"
                                "<!-- b -->\nother\n<!-- /b -->\n")
