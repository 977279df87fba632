"""`wsbuild pkg create`: names, safety, the template engine, and generated packages that build."""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator, Mapping
from pathlib import Path, PurePosixPath

import pytest
import yaml
from lxml import etree

from conftest import run_wsbuild, sigint_at_default
from wsbuild.errors import TemplateError, WsbuildError
from wsbuild.create.licenses import LICENSES, canonical_license, is_spdx_expression
from wsbuild.workspace.manifest import parse_manifest
from wsbuild.workspace.model import DepKind
from wsbuild.create.defaults import Maintainer, default_destination, default_maintainer
from wsbuild.create.templates import (
    TOKEN,
    available_build_types,
    render,
    render_package,
    templates_root,
)
from wsbuild.create.validation import PackageCreateError, PackageRequest
from wsbuild.create.writing import create_package
from wsbuild.underlay.detect import find_venv_underlay
from wsbuild.verbs.pkg import add_pkg_create_arguments, run_pkg_create

BUILD_TYPES = ("ament_cmake", "ament_python", "cmake")


def request(dest: Path, name: str = "my_pkg", **options: object) -> PackageRequest:
    fields: dict[str, object] = {"maintainer_name": "Jane Doe",
                                 "maintainer_email": "jane@example.com", **options}
    return PackageRequest(name=name, destination=dest, **fields)  # type: ignore[arg-type]


def tree(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def cli_args(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_pkg_create_arguments(parser)
    return parser.parse_args(argv)


# ------------------------------------------------------------------- names and safety


@pytest.mark.parametrize(("name", "build_type", "says"), [
    ("My-Pkg", "ament_python", "e.g. 'my_pkg'"),
    ("1pkg", "ament_cmake", "e.g. 'pkg'"),
    ("a-b", "cmake", "e.g. 'a_b'"),
    ("a__b", "ament_cmake", "consecutive underscores"),
    ("x", "ament_cmake", "at least two characters"),
    ("test", "ament_python", "test/ folder"),
    ("json", "ament_python", "standard library"),
    ("class", "ament_cmake", "keyword"),
    ("launch", "ament_python", "launch/ folder"),
])
def test_invalid_package_names_are_rejected_and_nothing_is_written(
        tmp_path: Path, name: str, build_type: str, says: str) -> None:
    with pytest.raises(PackageCreateError) as info:
        create_package(request(tmp_path, name, build_type=build_type))
    assert repr(name) in str(info.value) and says in str(info.value)
    assert str(info.value).count("REP 144") <= 1, str(info.value)
    assert tree(tmp_path) == []


@pytest.mark.parametrize(("options", "says"), [
    ({"node_name": "9lives"}, "invalid --node-name"),
    ({"node_name": "my-node"}, "invalid --node-name"),
    ({"library_name": "for"}, "keyword"),
    ({"node_name": "same", "library_name": "same"}, "both 'same'"),
    ({"launch": True}, "--launch needs --node-name"),
    ({"dependencies": ("rclpy", "bad dep")}, "invalid dependency name 'bad dep'"),
    ({"dependencies": ("my_pkg",)}, "cannot depend on itself"),
    ({"maintainer_email": "nobody"}, "invalid maintainer email"),
    ({"description": "two\nlines"}, "line break"),
    ({"license": "GPLv3"}, "GPL-3.0-only or GPL-3.0-or-later"),
    ({"license": "Apache License, Version 2.0!"}, "SPDX"),
    ({"build_type": "ament_cargo"}, "use one of: ament_cmake, ament_python, cmake"),
    ({"package_format": 1}, "unknown package format"),
])
def test_invalid_options_are_rejected_and_nothing_is_written(
        tmp_path: Path, options: dict[str, object], says: str) -> None:
    invalid = dataclasses.replace(request(tmp_path, build_type="ament_python"), **options)
    with pytest.raises(PackageCreateError) as info:
        create_package(invalid)
    assert says in str(info.value)
    assert tree(tmp_path) == []


def test_an_existing_directory_is_never_touched(tmp_path: Path) -> None:
    existing = tmp_path / "my_pkg"
    existing.mkdir()
    (existing / "keep.txt").write_text("mine")
    with pytest.raises(PackageCreateError, match="already exists; nothing was written"):
        create_package(request(tmp_path, build_type="ament_cmake", node_name="n"))
    assert tree(tmp_path) == ["my_pkg", "my_pkg/keep.txt"]
    (existing / "keep.txt").unlink()
    existing.rmdir()
    existing.symlink_to(tmp_path / "nowhere")  # a dangling symlink counts as existing too
    with pytest.raises(PackageCreateError, match="already exists"):
        create_package(request(tmp_path))


def test_a_failure_part_way_removes_what_was_written(tmp_path: Path) -> None:
    # --launch adds <exec_depend>launch_ros</exec_depend>: with <depend>launch_ros</depend>
    # the manifest is only found invalid after every file was written
    with pytest.raises(PackageCreateError, match="redundant"):
        create_package(request(tmp_path, build_type="ament_python", node_name="talker",
                               launch=True, dependencies=("launch_ros",)))
    assert tree(tmp_path) == []


def test_interrupt_while_writing_leaves_nothing(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    def interrupted(*args: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "rename", interrupted)
    with pytest.raises(KeyboardInterrupt):
        create_package(request(tmp_path, build_type="ament_cmake", library_name="lib"))
    assert tree(tmp_path) == []


def test_destination_inside_a_package_or_a_duplicate_name_is_rejected(tmp_path: Path) -> None:
    src = tmp_path / "ws" / "src"
    src.mkdir(parents=True)
    create_package(request(src, "first_pkg", build_type="ament_python"))
    with pytest.raises(PackageCreateError, match="inside the package 'first_pkg'"):
        create_package(request(src / "first_pkg" / "first_pkg", "nested_pkg"))
    (src / "repo").mkdir()
    with pytest.raises(PackageCreateError, match="already has a package named 'first_pkg'"):
        create_package(request(src / "repo", "first_pkg"))
    with pytest.raises(PackageCreateError, match="does not exist"):
        create_package(request(src / "missing", "other_pkg"))
    assert tree(src / "repo") == []


def test_created_package_is_readable_by_others(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        created = create_package(request(tmp_path, build_type="ament_cmake", node_name="n"))
    finally:
        os.umask(old)
    assert created.path.stat().st_mode & 0o777 == 0o755
    assert (created.path / "package.xml").stat().st_mode & 0o777 == 0o644
    assert [p.name for p in tmp_path.iterdir()] == ["my_pkg"]  # no staging leftovers


# ------------------------------------------------------------------- what gets generated


def all_requests(dest: Path) -> Iterator[PackageRequest]:
    """Every build type with every combination of options, with and without dependencies."""
    for build_type, node, library, launch, deps in itertools.product(
            BUILD_TYPES, (None, "my_node"), (None, "my_lib"), (False, True),
            ((), ("std_msgs",), ("rclcpp", "std_msgs"), ("rclpy",))):
        if launch and node is None:
            continue
        yield request(dest, build_type=build_type, node_name=node, library_name=library,
                      launch=launch, dependencies=deps, license="BSD-3-Clause", year=2031)


def test_every_combination_renders_to_valid_files(tmp_path: Path) -> None:
    count = 0
    for req in all_requests(tmp_path):
        rendered = render_package(req)
        files = dict(rendered.files)
        count += 1
        for path, content in files.items():
            where = f"{req.build_type} {rendered.variants} {path}"
            assert not TOKEN.search(content) or path.name == "LICENSE", f"leftover token: {where}"
            if path.suffix == ".py":
                compile(content, str(path), "exec")
            elif path.suffix == ".xml":
                etree.fromstring(content.encode())
            elif path.suffix == ".yaml":
                assert yaml.safe_load(content)
        assert "Copyright (c) 2031, Jane Doe" in files[PurePosixPath("LICENSE")]
        cmake = files.get(PurePosixPath("CMakeLists.txt"), "")
        assert "ament_target_dependencies" not in cmake
        for dep in req.dependencies:
            assert f"<depend>{dep}</depend>" in files[PurePosixPath("package.xml")]
            if cmake and (req.node_name or req.library_name):
                assert f"${{{dep}_TARGETS}}" in cmake
        if req.launch:
            assert {PurePosixPath("config/params.yaml"),
                    PurePosixPath("launch/my_node.launch.py"),
                    PurePosixPath("launch/my_node.launch.xml")} <= set(files)
            params = yaml.safe_load(files[PurePosixPath("config/params.yaml")])
            expected = {"greeting": "Hello from params.yaml"}
            assert params == {"my_node": {"ros__parameters": expected}}
    assert count == 3 * 4 * 6


@pytest.mark.parametrize("build_type", BUILD_TYPES)
def test_package_xml_parses_without_warnings(tmp_path: Path, build_type: str) -> None:
    created = create_package(request(
        tmp_path, build_type=build_type, node_name="talker", launch=True, package_format=2,
        dependencies=("std_msgs", "rclpy"), description='Says "hi" & <waves>',
        maintainer_name="Zoë O'Brien & co", license="apache-2.0"))
    warnings: list[str] = []
    package = parse_manifest(created.path / "package.xml", environ={},
                             known_build_types=BUILD_TYPES, warnings=warnings)
    assert warnings == []
    assert (package.name, package.build_type, package.version) == ("my_pkg", build_type, "0.0.0")
    assert package.description == 'Says "hi" & <waves>'
    assert package.licenses == ("Apache-2.0",)
    assert (package.maintainers[0].name, package.maintainers[0].email) == (
        "Zoë O'Brien & co", "jane@example.com")
    assert b'format="2"' in (created.path / "package.xml").read_bytes()
    build = {d.name for d in package.dependencies if d.kind is DepKind.BUILD}
    assert {"rclpy", "std_msgs"} <= build
    assert {"launch_ros", "ros2launch"} <= {d.name for d in package.dependencies
                                            if d.kind is DepKind.EXEC}
    assert "Apache License" in (created.path / "LICENSE").read_text()


def test_ament_python_setup_py_carries_the_metadata(tmp_path: Path) -> None:
    created = create_package(request(
        tmp_path, build_type="ament_python", node_name="talker", dependencies=("rclpy",),
        description="It's \\ tricky", launch=True))
    setup_py = (created.path / "setup.py").read_text()
    assert "'talker = my_pkg.talker:main'," in setup_py
    assert "description=\"It's \\\\ tricky\"," in setup_py
    assert "tests_require" not in setup_py and "pyproject" not in " ".join(tree(created.path))
    assert "rclpy.init(args=args)" in (created.path / "my_pkg" / "talker.py").read_text()
    plain = create_package(request(tmp_path, "plain_pkg", build_type="ament_python",
                                   node_name="talker"))
    assert "import rclpy" not in (plain.path / "plain_pkg" / "talker.py").read_text()
    assert "glob" not in (plain.path / "setup.py").read_text()


def test_rclcpp_in_the_dependencies_makes_an_rclcpp_node(tmp_path: Path) -> None:
    # rclcpp has no PyPI wheel: this variant is rendered and checked here, not built
    rendered = dict(render_package(request(tmp_path, build_type="ament_cmake", node_name="talker",
                                           dependencies=("rclcpp",))).files)
    source = rendered[PurePosixPath("src/talker.cpp")]
    assert "class Talker : public rclcpp::Node" in source
    assert 'declare_parameter<std::string>("greeting"' in source
    assert "${rclcpp_TARGETS}" in rendered[PurePosixPath("CMakeLists.txt")]


@pytest.mark.parametrize(("given", "written", "license_file"), [
    ("MIT", "MIT", True),
    ("bsd-3-clause", "BSD-3-Clause", True),
    ("GPL-3.0-or-later", "GPL-3.0-or-later", True),
    ("EPL-2.0", "EPL-2.0", False),
    ("Apache-2.0 OR MIT", "Apache-2.0 OR MIT", False),
    ("TODO: License declaration", "TODO: License declaration", False),
])
def test_license(tmp_path: Path, given: str, written: str, license_file: bool) -> None:
    created = create_package(request(tmp_path, build_type="cmake", license=given))
    assert f"<license>{written}</license>" in (created.path / "package.xml").read_text()
    assert (created.path / "LICENSE").exists() == license_file
    assert bool(created.notes) != license_file


def test_license_checks() -> None:
    assert canonical_license("apache 2.0") == ("apache 2.0", "Apache-2.0")
    assert canonical_license("BSD") == ("BSD", "BSD-3-Clause")
    assert canonical_license("GPL-3.0")[1] == "GPL-3.0-only or GPL-3.0-or-later"
    assert is_spdx_expression("(MIT OR Apache-2.0) AND BSD-3-Clause")
    assert is_spdx_expression("GPL-2.0-only WITH Classpath-exception-2.0")
    for bad in ("MIT OR", "OR MIT", "(MIT", "MIT)", "MIT Apache-2.0", "MIT; rm -rf /", ""):
        assert not is_spdx_expression(bad), bad
    root = templates_root()
    for entry in LICENSES:
        assert (root / "licenses" / f"{entry.text}.tmpl").is_file(), entry.spdx


def test_license_question_mark_lists_the_licenses(capsys: pytest.CaptureFixture[str]) -> None:
    assert run_pkg_create(cli_args("--license", "?")) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].split()[0] == "Apache-2.0"
    assert {line.split()[0] for line in out.splitlines()} == {e.spdx for e in LICENSES}


# ------------------------------------------------------------------- defaults


def test_destination_defaults_to_the_workspace_src(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    (ws / "src" / "repo").mkdir(parents=True)
    (ws / "build").mkdir()
    assert default_destination(ws) == ws / "src"
    assert default_destination(ws / "build") == ws / "src"
    assert default_destination(ws / "src" / "repo") == ws / "src" / "repo"
    (ws / "src" / "repo" / "pkg" / "pkg").mkdir(parents=True)
    (ws / "src" / "repo" / "pkg" / "package.xml").write_text("<package/>")
    assert default_destination(ws / "src" / "repo" / "pkg" / "pkg") == ws / "src" / "repo"
    assert default_destination(tmp_path) == tmp_path


def test_the_verb_creates_in_src_from_the_workspace_root(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    ws = tmp_path / "ws"
    (ws / "src").mkdir(parents=True)
    monkeypatch.chdir(ws)
    args = cli_args("my_pkg", "--build-type", "ament_python", "--node-name", "talker",
                    "--maintainer-name", "Jane", "--maintainer-email", "jane@example.com")
    assert run_pkg_create(args) == 0
    out, err = capsys.readouterr()
    assert (ws / "src" / "my_pkg" / "my_pkg" / "talker.py").is_file()
    assert "created ament_python package 'my_pkg' in src/my_pkg" in out
    assert "wsbuild run my_pkg talker" in out
    assert "no license chosen" in err
    with pytest.raises(WsbuildError, match="missing the package name"):
        run_pkg_create(cli_args())


def git_env(home: Path) -> dict[str, str]:
    return {"HOME": str(home), "GIT_CONFIG_NOSYSTEM": "1", "XDG_CONFIG_HOME": str(home)}


def test_maintainer_comes_from_git_config(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    for key, value in git_env(tmp_path).items():
        monkeypatch.setenv(key, value)
    monkeypatch.delenv("GIT_CONFIG_GLOBAL", raising=False)
    repo = tmp_path / "repo"
    repo.mkdir()
    subprocess.run(["git", "init", "-q", str(repo)], check=True)
    subprocess.run(["git", "-C", str(repo), "config", "user.name", "Ada Lovelace"], check=True)
    subprocess.run(["git", "-C", str(repo), "config", "user.email", "ada@example.org"], check=True)
    assert default_maintainer(repo) == Maintainer("Ada Lovelace", "ada@example.org")
    fallback = default_maintainer(tmp_path)  # not in the repository: no git identity at all
    assert fallback.email.endswith("@todo.todo") and fallback.note is not None
    assert "--maintainer-email" in fallback.note


# ------------------------------------------------------------------- the template engine


def test_render_substitutes_values_and_fills_slots_with_indentation(tmp_path: Path) -> None:
    text = "project(@name@)\n@PACKAGE_INIT@\nlist(\n  @items@\n)\n  @empty@\nend\n"
    out = render(text, {"name": "demo"}, source=tmp_path / "t",
                 slots={"items": "a\n\nb\n", "empty": ""})
    assert out == "project(demo)\n@PACKAGE_INIT@\nlist(\n  a\n\n  b\n)\nend\n"


@pytest.mark.parametrize(("text", "says"), [
    ("line one\nuses @unknown@ here\n", "unknown token @unknown@"),
    ("x @slot@\n", "must stand alone on its line"),
])
def test_render_errors_name_the_file_and_line(tmp_path: Path, text: str, says: str) -> None:
    with pytest.raises(TemplateError) as info:
        render(text, {"name": "demo"}, source=tmp_path / "CMakeLists.txt.tmpl",
               slots={"slot": "a\n"})
    assert says in str(info.value)
    assert str(info.value).startswith(f"{tmp_path / 'CMakeLists.txt.tmpl'}:")


def write_templates(root: Path, files: Mapping[str, str]) -> Path:
    """A template root with one build type `demo` (plus the real licenses)."""
    for relative, content in files.items():
        path = root / "pkg" / "demo" / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(content)
    (root / "licenses").symlink_to(templates_root() / "licenses")
    return root


DEMO_BASE = {
    "base/files/package.xml.tmpl": (templates_root() / "pkg" / "cmake" / "base" / "files"
                                    / "package.xml.tmpl").read_text(),
    "base/files/list.txt.tmpl": "@items@\n",
    "base/slots/items.tmpl": "items:\n",
    "dependency/slots/package_xml_depends.tmpl": "<depend>@dependency@</depend>\n",
    "dependency/slots/package_xml_exec_depends.tmpl": "",
    "dependency/slots/deps.tmpl": "- @dependency@\n",
}


def test_a_new_flavour_is_a_new_folder(tmp_path: Path) -> None:
    root = write_templates(tmp_path / "t", {
        **DEMO_BASE,
        "node/files/@node_name@.txt.tmpl": "plain\n",
        "node/slots/items.tmpl": "node @node_name@ uses:\n@deps@\n",
        "node+special/files/@node_name@.txt.tmpl": "special\n",
        "node+special/slots/items.tmpl": "special node\n",
    })
    assert available_build_types(root) == ("demo",)
    plain = dict(render_package(request(tmp_path, build_type="demo", node_name="n",
                                        dependencies=("b", "a")), root=root).files)
    assert plain[PurePosixPath("n.txt")] == "plain\n"
    assert plain[PurePosixPath("list.txt")] == "items:\nnode n uses:\n- a\n- b\n"
    special = render_package(request(tmp_path, build_type="demo", node_name="n",
                                     dependencies=("special",)), root=root)
    assert special.variants == ("base", "node+special")
    assert dict(special.files)[PurePosixPath("n.txt")] == "special\n"
    with pytest.raises(PackageCreateError, match="demo packages have no --library-name"):
        render_package(request(tmp_path, build_type="demo", library_name="l"), root=root)


@pytest.mark.parametrize(("extra", "says"), [
    ({"library/slots/nowhere.tmpl": "x\n"}, "fragments for @nowhere@ are used by no file"),
    ({"library/files/list.txt.tmpl": "again\n"}, "two templates write list.txt"),
    ({"library/files/README": "x\n"}, "end in .tmpl"),
    ({"library/notes.txt": "x\n"}, "holds only files/ and slots/"),
    ({"library/slots/items.tmpl": "no line break"}, "must end with a line break"),
    ({"library/slots/items.tmpl": "@deps@ inline\n"}, "must stand alone"),
])
def test_broken_templates_are_template_errors(tmp_path: Path, extra: Mapping[str, str],
                                              says: str) -> None:
    root = write_templates(tmp_path / "t", {**DEMO_BASE, **extra})
    with pytest.raises(WsbuildError) as info:
        create_package(request(tmp_path, build_type="demo", library_name="lib",
                               dependencies=("a",)), root=root)
    assert says in str(info.value)
    assert [p.name for p in tmp_path.iterdir()] == ["t"]


def test_shipped_templates_follow_the_rules() -> None:
    root = templates_root()
    for path in (root / "pkg").rglob("*"):
        relative = path.relative_to(root / "pkg")
        if path.is_file():
            assert path.name.endswith(".tmpl"), relative
            assert relative.parts[2] in ("files", "slots"), relative
    assert set(available_build_types()) == set(BUILD_TYPES)


# ------------------------------------------------------------------- real builds

ROS = find_venv_underlay(os.environ, sys.executable)
ROS_DOMAIN_ID = "61"

#: name -> options: every build type, with and without node, library, launch and dependencies
WORKSPACE: dict[str, dict[str, object]] = {
    "py_bare": {"build_type": "ament_python"},
    "py_plain": {"build_type": "ament_python", "node_name": "hello"},
    "cpp_bare": {"build_type": "ament_cmake"},
    "cpp_pkg": {"build_type": "ament_cmake", "dependencies": ("std_msgs",), "node_name": "hello",
                "library_name": "greeter", "launch": True, "license": "BSD-3-Clause"},
    "cm_bare": {"build_type": "cmake"},
    "cm_pkg": {"build_type": "cmake", "dependencies": ("cpp_pkg",), "node_name": "hello",
               "library_name": "shouter", "launch": True, "license": "MIT"},
    "cpp_user": {"build_type": "ament_cmake", "dependencies": ("cm_pkg",), "node_name": "user"},
}
#: made through the command line, from the workspace root (so it lands in src/)
CLI_PACKAGE = ("py_pkg", "--build-type", "ament_python", "--dependencies", "rclpy", "std_msgs",
               "--node-name", "talker", "--library-name", "util", "--launch",
               "--license", "Apache-2.0", "--maintainer-name", "Jane",
               "--maintainer-email", "jane@example.com")
PACKAGES = sorted([*WORKSPACE, CLI_PACKAGE[0]])
NODES = {"py_plain": "hello", "cpp_pkg": "hello", "cm_pkg": "hello", "cpp_user": "user"}
LAUNCHED = ("py_pkg", "cpp_pkg", "cm_pkg")


def ros_env() -> dict[str, str]:
    """A fresh terminal: nothing sourced, DDS on this machine and on a domain of our own."""
    sourced = ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "COLCON_PREFIX_PATH", "LD_LIBRARY_PATH",
               "PYTHONPATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE")
    env = {k: v for k, v in os.environ.items() if k not in sourced}
    env.update(ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=ROS_DOMAIN_ID,
               PYTHONDONTWRITEBYTECODE="1")
    return env


def sourced(ws: Path, command: str, *, cwd: Path | None = None,
            timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """`command` in bash after `source install/setup.bash`."""
    script = f"source {ws / 'install' / 'setup.bash'} && {command}"
    return subprocess.run(["bash", "-c", script], cwd=cwd or ws, env=ros_env(), text=True,
                          capture_output=True, timeout=timeout)


def cli_has_pkg_create() -> bool:
    from wsbuild.cli import build_parser

    verbs = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    return any("pkg" in action.choices for action in verbs)


def pkg_create_command(*argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """`wsbuild pkg create ARGV` in a subprocess (through run_pkg_create until cli.py has it)."""
    if cli_has_pkg_create():
        return run_wsbuild("pkg", "create", *argv, cwd=cwd, env=ros_env(), timeout=60)
    script = ("import argparse, sys; from wsbuild.errors import WsbuildError; "
              "from wsbuild.verbs.pkg import add_pkg_create_arguments, run_pkg_create\n"
              "p = argparse.ArgumentParser(); add_pkg_create_arguments(p)\n"
              "try: sys.exit(run_pkg_create(p.parse_args(sys.argv[1:])))\n"
              "except WsbuildError as e: print(f'wsbuild: error: {e}', file=sys.stderr); "
              "sys.exit(e.exit_code)")
    return subprocess.run([sys.executable, "-c", script, *argv], cwd=cwd, env=ros_env(),
                          text=True, capture_output=True, timeout=60)


@pytest.mark.parametrize("argv", [
    ("My-Pkg",),
    ("my_pkg", "--build-type", "ament_python", "--launch"),
])
def test_command_line_errors_are_one_line_and_exit_2(tmp_path: Path,
                                                     argv: tuple[str, ...]) -> None:
    (tmp_path / "src").mkdir()
    result = pkg_create_command(*argv, cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.startswith("wsbuild: error: ") and result.stderr.count("\n") == 1
    assert tree(tmp_path) == ["src"]


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One workspace holding a package of every kind, created by pkg create and built once."""
    ws = tmp_path_factory.mktemp("pkgcreate") / "ws"
    (ws / "src").mkdir(parents=True)
    for name, options in WORKSPACE.items():
        create_package(request(ws / "src", name, **options))
    made = pkg_create_command(*CLI_PACKAGE, cwd=ws)
    assert made.returncode == 0, made.stderr
    result = run_wsbuild("build", "--packages-select", *PACKAGES, cwd=ws, env=ros_env())
    assert result.returncode == 0, f"{result.stdout}\n{result.stderr}"
    return ws


def requires_ros(func):  # type: ignore[no-untyped-def]
    """Real builds against the ROS 2 wheel underlay of the running virtualenv."""
    for mark in (pytest.mark.ros, pytest.mark.slow,
                 pytest.mark.skipif(ROS is None, reason="needs the ROS 2 wheel underlay")):
        func = mark(func)
    return func


@requires_ros
@pytest.mark.parametrize("package", sorted(NODES))
def test_generated_executables_run(built: Path, package: str) -> None:
    node = NODES[package]
    result = run_wsbuild("run", package, node, cwd=built, env=ros_env(), timeout=60)
    assert result.returncode == 0, result.stderr
    assert f"Hello from {node} in {package}" in result.stdout
    if WORKSPACE.get(package, {}).get("library_name"):  # the node links the package's library
        assert f"Hello, {package}!" in result.stdout, result.stdout


def test_the_node_tests_leave_the_words_to_the_node(tmp_path: Path) -> None:
    """Any edit to what the generated node says leaves its generated test passing: the test
    checks that it runs, not its words."""
    (tmp_path / "src").mkdir()
    made = pkg_create_command("says", "--build-type", "ament_python", "--node-name", "hello",
                              cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    node = tmp_path / "src" / "says" / "says" / "hello.py"
    node.write_text(node.read_text().replace("Hello from hello", "Good morning"))
    result = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                             "test/test_hello.py"], cwd=tmp_path / "src" / "says",
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    for build_type in ("ament_cmake", "cmake"):
        rendered = dict(render_package(request(tmp_path, build_type=build_type,
                                               node_name="hello")).files)
        # CTest's check of the node: it runs and exits 0, whatever it prints
        assert "PASS_REGULAR_EXPRESSION" not in rendered[PurePosixPath("CMakeLists.txt")]


def run_until(command: list[str], expected: str, *, cwd: Path, timeout: float = 30) -> str:
    """Start `command` in its own process group; return its output once `expected` appears
    (or the time is up, or it exits), always stopping the whole group."""
    process = subprocess.Popen(command, cwd=cwd, env=ros_env(), stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, start_new_session=True,
                               preexec_fn=sigint_at_default)
    assert process.stdout is not None
    fd = process.stdout.fileno()
    seen = b""
    deadline = time.monotonic() + timeout
    try:
        while expected.encode() not in seen and time.monotonic() < deadline:
            ready, _, _ = select.select([fd], [], [], 0.1)
            if ready:
                chunk = os.read(fd, 65536)
                if not chunk:
                    break  # the process exited
                seen += chunk
    finally:
        for sig in (signal.SIGINT, signal.SIGKILL):
            try:
                os.killpg(process.pid, sig)
                process.wait(timeout=5)
                break
            except ProcessLookupError:
                break
            except subprocess.TimeoutExpired:
                continue
        process.stdout.close()
    return seen.decode(errors="replace")


@requires_ros
def test_rclpy_node_logs_its_parameter_from_the_yaml(built: Path) -> None:
    params = built / "install" / "py_pkg" / "share" / "py_pkg" / "config" / "params.yaml"
    out = run_until([sys.executable, "-m", "wsbuild", "run", "py_pkg", "talker", "--ros-args",
                     "--params-file", str(params)], "greeting: Hello from params.yaml",
                    cwd=built)
    assert "[talker]: greeting: Hello from params.yaml" in out, out


@requires_ros
def test_installed_launch_and_config_files_are_found(built: Path) -> None:
    probe = ("from ament_index_python.packages import get_package_share_directory as share; "
             f"print('\\n'.join(share(p) for p in {list(LAUNCHED)!r}))")
    result = sourced(built, f"{sys.executable} -c \"{probe}\"")
    assert result.returncode == 0, result.stderr
    shares = [Path(line) for line in result.stdout.split()]
    assert shares == [built / "install" / p / "share" / p for p in LAUNCHED]
    for share, node in zip(shares, ("talker", "hello", "hello")):
        launch_py = share / "launch" / f"{node}.launch.py"
        compile(launch_py.read_text(), str(launch_py), "exec")  # launch itself has no wheel
        launch = etree.parse(str(share / "launch" / f"{node}.launch.xml")).getroot()
        assert launch.find("node").get("exec") == node
        params = yaml.safe_load((share / "config" / "params.yaml").read_text())
        assert params[node]["ros__parameters"]["greeting"] == "Hello from params.yaml"


@requires_ros
@pytest.mark.parametrize(("package", "passed"), [("py_bare", 1), ("py_plain", 2), ("py_pkg", 4)])
def test_generated_python_tests_pass(built: Path, package: str, passed: int) -> None:
    # the template's flake8 and pep257 tests run too: the ros extra installs those linters
    result = sourced(built, f"{sys.executable} -m pytest -q -p no:cacheprovider -rs",
                     cwd=built / "src" / package)
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"{passed + 2} passed" in result.stdout and "skipped" not in result.stdout


@requires_ros
@pytest.mark.parametrize(("package", "tests"), [
    ("cpp_pkg", ["test_greeter", "hello_runs"]),
    ("cm_pkg", ["test_shouter", "hello_runs"]),
    ("cpp_user", ["user_runs"]),
])
def test_generated_cmake_tests_pass(built: Path, package: str, tests: list[str]) -> None:
    result = sourced(built, f"ctest --test-dir build/{package} --output-on-failure")
    assert result.returncode == 0, result.stdout + result.stderr
    for name in tests:
        assert f" {name} " in result.stdout and "100% tests passed" in result.stdout


@requires_ros
def test_the_cmake_library_is_found_by_dependents(built: Path) -> None:
    cache = (built / "build" / "cpp_user" / "CMakeCache.txt").read_text()
    assert f"cm_pkg_DIR:PATH={built / 'install' / 'cm_pkg' / 'share' / 'cm_pkg' / 'cmake'}" in cache
    header = built / "install" / "cpp_pkg" / "include" / "cpp_pkg" / "cpp_pkg" / "greeter.hpp"
    assert header.is_file()
