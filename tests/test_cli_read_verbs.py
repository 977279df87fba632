"""`wsbuild list|graph|info` as a user runs them, including every bad-input path."""

from __future__ import annotations

import json
from pathlib import Path

import pytest


BAD_MANIFESTS = {
    "not_xml": "<package format='3'><name>x</name",
    "wrong_root": "<?xml version='1.0'?><manifest><name>x</name></manifest>",
    "missing_name": """<?xml version="1.0"?><package format="3"><version>1.0.0</version>
<description>d</description><maintainer email="a@b.c">m</maintainer><license>MIT</license>
</package>""",
    "invalid_name": """<?xml version="1.0"?><package format="3"><name>My-Pkg</name>
<version>1.0.0</version><description>d</description>
<maintainer email="a@b.c">m</maintainer><license>MIT</license></package>""",
    "path_name": """<?xml version="1.0"?><package format="3"><name>../x</name>
<version>1.0.0</version><description>d</description>
<maintainer email="a@b.c">m</maintainer><license>MIT</license></package>""",
    "shell_name": """<?xml version="1.0"?><package format="3"><name>$(touch x)</name>
<version>1.0.0</version><description>d</description>
<maintainer email="a@b.c">m</maintainer><license>MIT</license></package>""",
    "unknown_format": """<?xml version="1.0"?><package format="9"><name>x</name>
<version>1.0.0</version><description>d</description>
<maintainer email="a@b.c">m</maintainer><license>MIT</license></package>""",
    "bad_condition": """<?xml version="1.0"?><package format="3"><name>x</name>
<version>1.0.0</version><description>d</description>
<maintainer email="a@b.c">m</maintainer><license>MIT</license>
<depend condition="$ROS_VERSION == ">rclpy</depend></package>""",
    "unknown_build_type": """<?xml version="1.0"?><package format="3"><name>x</name>
<version>1.0.0</version><description>d</description>
<maintainer email="a@b.c">m</maintainer><license>MIT</license>
<export><build_type>bazel</build_type></export></package>""",
}


@pytest.mark.parametrize("case", sorted(BAD_MANIFESTS))
def test_bad_manifest_is_one_line_error_exit_2(case: str, tmp_path: Path, wsbuild) -> None:  # type: ignore[no-untyped-def]
    pkg = tmp_path / "src" / "pkg"
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text(BAD_MANIFESTS[case])
    (pkg / "CMakeLists.txt").write_text("project(x)\n")
    result = wsbuild("list", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert str(pkg / "package.xml") in lines[0]
    assert not (tmp_path / "x").exists()  # nothing from the manifest was executed


def test_list_formats(make_workspace, wsbuild) -> None:  # type: ignore[no-untyped-def]
    ws = make_workspace({"app": ("ament_python", ["lib"]), "lib": ("ament_cmake", [])})
    plain = wsbuild("list", cwd=ws)
    assert plain.stdout.splitlines() == ["app\tsrc/app\t(ament_python)",
                                         "lib\tsrc/lib\t(ament_cmake)"]
    assert wsbuild("list", "-t", "-n", cwd=ws).stdout.split() == ["lib", "app"]
    assert wsbuild("list", "-p", cwd=ws / "src" / "app").stdout.split() == ["src/app", "src/lib"]
    rows = json.loads(wsbuild("list", "--json", "--deps", cwd=ws).stdout)
    app = next(r for r in rows if r["name"] == "app")
    assert {"name": "lib", "resolution": "workspace"}.items() <= app["dependencies"][0].items()


def test_unknown_package_is_error_with_suggestion(make_workspace, wsbuild) -> None:  # type: ignore[no-untyped-def]
    ws = make_workspace({"talker": ("ament_python", [])})
    result = wsbuild("list", "--packages-select", "talkr", cwd=ws)
    assert result.returncode == 2
    assert "did you mean 'talker'" in result.stderr
    info = wsbuild("info", "talkr", cwd=ws)
    assert info.returncode == 2 and "did you mean 'talker'" in info.stderr


def test_cycle_error(make_workspace, wsbuild) -> None:  # type: ignore[no-untyped-def]
    ws = make_workspace({"a": ("cmake", ["b"]), "b": ("cmake", ["a"])})
    result = wsbuild("list", cwd=ws)
    assert result.returncode == 2
    assert "a → b → a" in result.stderr


def test_graph_outputs_distinguish_edge_kinds(make_workspace, wsbuild) -> None:  # type: ignore[no-untyped-def]
    ws = make_workspace({
        "app": ("ament_python", [], {"build_depend": ["lib"], "exec_depend": ["viz"],
                                     "test_depend": ["checker"]}),
        "lib": ("cmake", []), "viz": ("cmake", []), "checker": ("cmake", []),
    })
    text = wsbuild("graph", cwd=ws).stdout
    assert "  build  lib" in text and "  run    viz" in text and "  test   checker" in text
    dot = wsbuild("graph", "--dot", cwd=ws).stdout
    assert '"app" -> "lib" [style=solid' in dot and '"app" -> "viz" [style=dashed' in dot
    assert '"app" -> "checker" [style=dotted' in dot
    mermaid = wsbuild("graph", "--mermaid", cwd=ws).stdout
    assert "app -->|build| lib" in mermaid and "app -.->|run| viz" in mermaid


def test_info_shows_resolution(make_workspace, wsbuild) -> None:  # type: ignore[no-untyped-def]
    ws = make_workspace({
        "app": ("ament_python", ["lib", "no_such_ros_pkg", "python3-yaml", "libfoo-dev"]),
        "lib": ("cmake", []),
    })
    out = wsbuild("info", "app", cwd=ws).stdout
    lines = {line.split()[0]: line for line in out.splitlines()[5:] if line.strip()}
    assert "workspace" in lines["lib"]
    assert "unresolved" in lines["no_such_ros_pkg"]
    assert "python distribution (PyYAML" in lines["python3-yaml"]
    assert "system" in lines["libfoo-dev"]


def test_help_reads_like_documentation(wsbuild, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    out = wsbuild("build", "--help", cwd=tmp_path).stdout
    assert "--packages-up-to" in out and "--symlink-install" in out and "examples:" in out


def test_violated_version_constraint_is_reported(make_workspace, wsbuild) -> None:  # type: ignore[no-untyped-def]
    ws = make_workspace({"app": ("cmake", []), "lib": ("cmake", [])})
    xml = ws / "src" / "app" / "package.xml"
    xml.write_text(xml.read_text().replace(
        "<export>", '<depend version_gte="2.0.0">lib</depend>\n  <export>'))
    result = wsbuild("list", cwd=ws)
    assert result.returncode == 0
    assert "lib" in result.stderr and "2.0.0" in result.stderr and str(xml) in result.stderr


def test_info_names_what_wsbuild_stands_in_for_as_deps_does(tmp_path: Path) -> None:
    """ament_lint_auto and ament_lint_common have no wheel: `wsbuild deps` and the build say
    wsbuild stands in for them, and so does `info` (also `list --deps`), not "unresolved"."""
    from conftest import run_wsbuild, write_package

    ws = tmp_path / "ws"
    write_package(ws / "src", "linted", "ament_cmake",
                  kinds={"test_depend": ["ament_lint_auto", "ament_lint_common"]})
    info = run_wsbuild("info", "linted", cwd=ws)
    assert info.returncode == 0, info.stderr
    lines = {line.split()[0]: line for line in info.stdout.splitlines()[5:] if line.strip()}
    shim = ws / "build" / ".wsbuild" / "lint_shim"
    for name in ("ament_lint_auto", "ament_lint_common"):
        assert lines[name].endswith(f"stood in for by wsbuild ({shim})"), lines[name]
    assert "unresolved" not in info.stdout
    deps = run_wsbuild("deps", cwd=ws)
    assert "stood in for by wsbuild" in deps.stdout and "ament_lint_auto" in deps.stdout
    listed = run_wsbuild("list", "--deps", cwd=ws).stdout
    assert "  ament_lint_auto\ttest_depend\tstood in for by wsbuild" in listed
