"""The ament_python build type: real setuptools, real packages in tmp_path."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import pytest

from wsbuild.build_types import PackageContext, BuildOptions, StepFailed, get_build_type
from wsbuild.workspace.model import Package
from wsbuild.build_types.pybuild.paths import site_packages_relpath
from wsbuild.build_types.pybuild.setup_py import SETUP_LOG, shutdown_helpers

SITE = site_packages_relpath()

SETUP_PY = """\
import os
from glob import glob
from setuptools import find_packages, setup
{imports}
package_name = '{name}'

setup(
    name=package_name,
    version='0.3.1',
    packages=find_packages(exclude=['test']),
    data_files=[
{index}{manifest}        (os.path.join('share', package_name, 'launch'), glob('launch/*.launch.py')),
        (os.path.join('share', package_name, 'config'), glob('config/*.yaml')),
        (os.path.join('share', package_name, 'urdf'), glob('urdf/*.urdf')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Jane Doe',
    maintainer_email='jane@example.com',
    description='A talker',
    license='Apache-2.0',
    extras_require={{'test': ['pytest']}},
    entry_points={{
        'console_scripts': [
            'talker = {name}.talker:main',
        ],
    }},{extra}
)
"""

INDEX = "        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),\n"
MANIFEST = "        ('share/' + package_name, ['package.xml']),\n"

CMDCLASS_IMPORTS = """\
from setuptools.command.build_py import build_py


class BuildPy(build_py):
    def run(self):
        super().run()
"""


def write_package(root: Path, name: str, *, index: bool = True, manifest: bool = True,
                  cmdclass: bool = False) -> Path:
    """An ament_python package as `ros2 pkg create --build-type ament_python` makes it."""
    pkg = root / name
    (pkg / name).mkdir(parents=True)
    (pkg / "resource").mkdir()
    (pkg / "resource" / name).write_text("")
    (pkg / "launch").mkdir()
    (pkg / "launch" / "talk.launch.py").write_text("GREETING = 'launch v1'\n")
    (pkg / "config").mkdir()
    (pkg / "config" / "params.yaml").write_text("rate: 10\n")
    (pkg / "urdf").mkdir()
    (pkg / "urdf" / "robot.urdf").write_text("<robot name='r'/>\n")
    (pkg / "test").mkdir()
    (pkg / "test" / "test_talker.py").write_text("def test_nothing():\n    pass\n")
    (pkg / name / "__init__.py").write_text("")
    (pkg / name / "words.py").write_text("WORD = 'hello v1'\n")
    (pkg / name / "talker.py").write_text(
        f"from {name}.words import WORD\n\n\ndef main():\n    print(WORD)\n")
    (pkg / "package.xml").write_text(f"""<?xml version="1.0"?>
<package format="3">
  <name>{name}</name>
  <version>0.3.1</version>
  <description>A talker</description>
  <maintainer email="jane@example.com">Jane Doe</maintainer>
  <license>Apache-2.0</license>
  <exec_depend>rclpy</exec_depend>
  <export><build_type>ament_python</build_type></export>
</package>
""")
    (pkg / "setup.cfg").write_text(
        f"[develop]\nscript_dir=$base/lib/{name}\n[install]\ninstall_scripts=$base/lib/{name}\n")
    (pkg / "setup.py").write_text(SETUP_PY.format(
        name=name, index=INDEX if index else "", manifest=MANIFEST if manifest else "",
        imports=CMDCLASS_IMPORTS if cmdclass else "",
        extra="\n    cmdclass={'build_py': BuildPy}," if cmdclass else ""))
    return pkg


def subprocess_runner(log: list[str]):
    def run(command: Sequence[str], *, cwd: Path, env: Mapping[str, str] | None = None) -> None:
        completed = subprocess.run(list(command), cwd=cwd, env=env, capture_output=True,
                                   text=True)
        log.append(completed.stdout + completed.stderr)
        if completed.returncode:
            raise StepFailed(f"{command[0]} failed", command=command, cwd=cwd,
                             returncode=completed.returncode)
    return run


def make_ctx(source: Path, workspace: Path, *, symlink: bool = False,
             environ: Mapping[str, str] | None = None) -> tuple[PackageContext, list[str], list[str]]:
    name = source.name
    build_dir = workspace / "build" / name
    build_dir.mkdir(parents=True, exist_ok=True)
    stage = workspace / "install" / f".{name}.stage"
    if stage.exists():
        shutil.rmtree(stage)
    stage.mkdir(parents=True)
    warnings: list[str] = []
    output: list[str] = []
    package = Package(name=name, path=source, build_type="ament_python",
                      manifest=source / "package.xml")
    ctx = PackageContext(
        package=package, build_dir=build_dir, install_prefix=workspace / "install" / name,
        stage_prefix=stage,
        options=BuildOptions(symlink_install=symlink, python_executable=sys.executable),
        environ=dict(os.environ if environ is None else environ),
        run=subprocess_runner(output), warn=warnings.append)
    return ctx, warnings, output


def build(source: Path, workspace: Path, **kwargs: object) -> tuple[PackageContext, list[str], str]:
    """Run every step, then move the stage into place as the orchestrator does."""
    ctx, warnings, output = make_ctx(source, workspace, **kwargs)  # type: ignore[arg-type]
    for step in get_build_type("ament_python").steps(ctx):
        step.action(ctx)
    if ctx.install_prefix.exists():
        shutil.rmtree(ctx.install_prefix)
    ctx.stage_prefix.rename(ctx.install_prefix)
    log = (ctx.build_dir / SETUP_LOG).read_text() if (ctx.build_dir / SETUP_LOG).exists() else ""
    return ctx, warnings, log + "".join(output)


def tree(prefix: Path) -> dict[str, str]:
    """relative path -> 'file' / 'link' for everything below prefix (links not followed)."""
    found = {}
    for root, dirs, files in os.walk(prefix):
        for name in dirs + files:
            path = Path(root) / name
            rel = path.relative_to(prefix).as_posix()
            if path.is_symlink():
                found[rel] = "link"
            elif path.is_file():
                found[rel] = "file"
    return found


def run_script(prefix: Path, script: Path) -> str:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(prefix / SITE)
    return subprocess.run([str(script)], env=env, capture_output=True, text=True,
                          check=True).stdout


def no_bytecode_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


@pytest.fixture(scope="module", autouse=True)
def _helpers() -> Iterator[None]:
    yield
    shutdown_helpers()


EGG = f"{SITE}/talker_py-0.3.1-py{sys.version_info[0]}.{sys.version_info[1]}.egg-info"
EXPECTED = {
    "lib/talker_py/talker",
    f"{SITE}/talker_py/__init__.py",
    f"{SITE}/talker_py/talker.py",
    f"{SITE}/talker_py/words.py",
    *(f"{EGG}/{f}" for f in ("PKG-INFO", "SOURCES.txt", "dependency_links.txt",
                             "entry_points.txt", "requires.txt", "top_level.txt", "zip-safe")),
    "share/ament_index/resource_index/packages/talker_py",
    "share/talker_py/package.xml",
    "share/talker_py/launch/talk.launch.py",
    "share/talker_py/config/params.yaml",
    "share/talker_py/urdf/robot.urdf",
}


def expected_files() -> set[str]:
    """EXPECTED, with the modules' bytecode where Python writes it (as setuptools' install
    does under colcon: not with PYTHONDONTWRITEBYTECODE set)."""
    if sys.dont_write_bytecode:
        return EXPECTED
    tag = sys.implementation.cache_tag
    return EXPECTED | {f"{SITE}/talker_py/__pycache__/{module}.{tag}.pyc"
                       for module in ("__init__", "talker", "words")}


def test_installs_colcon_layout_and_console_script_runs(tmp_path: Path) -> None:
    source = write_package(tmp_path / "src", "talker_py")
    ctx, warnings, output = build(source, tmp_path)
    prefix = ctx.install_prefix
    assert {p for p, kind in tree(prefix).items() if kind == "file"} == expected_files()
    assert warnings == []
    assert run_script(prefix, prefix / "lib/talker_py/talker") == "hello v1\n"
    script = (prefix / "lib/talker_py/talker").read_text()
    assert script.startswith(f"#!{sys.executable}\n")
    assert (prefix / f"{EGG}/entry_points.txt").read_text() == \
        "[console_scripts]\ntalker = talker_py.talker:main\n"
    assert "SetuptoolsDeprecationWarning" not in output
    assert "setup.py install is deprecated" not in output


def test_source_directory_stays_clean(tmp_path: Path) -> None:
    source = write_package(tmp_path / "src", "talker_py")
    before = sorted(p.relative_to(source) for p in source.rglob("*"))
    build(source, tmp_path)
    build(source, tmp_path, symlink=True)
    ctx, _, _ = build(source, tmp_path, environ=no_bytecode_env())
    after = sorted(p.relative_to(source) for p in source.rglob("*"))
    assert after == before
    assert (ctx.build_dir / "talker_py.egg-info" / "PKG-INFO").is_file()


def test_layout_matches_setuptools_install_as_colcon_runs_it(tmp_path: Path) -> None:
    # colcon: setup.py egg_info --egg-base <build> build --build-base <build>/build install
    # --prefix <install> --record <build>/install.log --single-version-externally-managed
    source = write_package(tmp_path / "src", "talker_py")
    env = no_bytecode_env()
    colcon_build = tmp_path / "colcon_build"
    colcon_install = tmp_path / "colcon_install"
    colcon_build.mkdir()
    subprocess.run(
        [sys.executable, "setup.py", "egg_info", "--egg-base",
         os.path.relpath(colcon_build, source), "build", "--build-base",
         str(colcon_build / "build"), "install", "--prefix", str(colcon_install), "--record",
         str(colcon_build / "install.log"), "--single-version-externally-managed"],
        cwd=source, env=env, check=True, capture_output=True)
    ctx, _, _ = build(source, tmp_path / "ws", environ=env)
    ours = tree(ctx.install_prefix)
    theirs = tree(colcon_install)
    assert set(ours) == set(theirs)
    assert any(p.endswith(".pyc") for p in ours)  # byte-compiled like setup.py install
    egg = Path(EGG)
    for name in ("PKG-INFO", "entry_points.txt", "requires.txt", "top_level.txt"):
        assert (ctx.install_prefix / egg / name).read_text() == \
            (colcon_install / egg / name).read_text()


def test_bytecode_names_final_install_path(tmp_path: Path) -> None:
    import marshal

    source = write_package(tmp_path / "src", "talker_py")
    ctx, _, _ = build(source, tmp_path, environ=no_bytecode_env())
    cache = next((ctx.install_prefix / SITE / "talker_py" / "__pycache__").glob("words.*.pyc"))
    code = marshal.loads(cache.read_bytes()[16:])
    assert code.co_filename == str(ctx.install_prefix / SITE / "talker_py" / "words.py")


def test_missing_marker_and_manifest_are_installed_with_warnings(tmp_path: Path) -> None:
    source = write_package(tmp_path / "src", "talker_py", index=False, manifest=False)
    ctx, warnings, _ = build(source, tmp_path)
    marker = ctx.install_prefix / "share/ament_index/resource_index/packages/talker_py"
    assert marker.is_file() and marker.read_text() == ""
    assert (ctx.install_prefix / "share/talker_py/package.xml").read_text() == \
        (source / "package.xml").read_text()
    assert len(warnings) == 2
    assert "('share/ament_index/resource_index/packages', ['resource/talker_py'])" in warnings[0]
    assert "('share/talker_py', ['package.xml'])" in warnings[1]
    assert all("data_files in setup.py" in w for w in warnings)


def test_symlink_install_sees_source_edits_without_rebuild(tmp_path: Path) -> None:
    source = write_package(tmp_path / "src", "talker_py")
    ctx, warnings, _ = build(source, tmp_path, symlink=True)
    prefix = ctx.install_prefix
    assert warnings == []
    assert run_script(prefix, prefix / "lib/talker_py/talker") == "hello v1\n"
    # (another length: the run above may have written the module's bytecode beside the
    # source, and Python takes it as current while the source's size and mtime second match)
    (source / "talker_py" / "words.py").write_text("WORD = 'hello version 2'\n")
    (source / "launch" / "talk.launch.py").write_text("GREETING = 'launch v2'\n")
    assert run_script(prefix, prefix / "lib/talker_py/talker") == "hello version 2\n"
    assert (prefix / "share/talker_py/launch/talk.launch.py").read_text() == \
        "GREETING = 'launch v2'\n"
    kinds = tree(prefix)
    assert kinds["lib/talker_py/talker"] == "file"  # generated, not linked
    assert kinds[f"{SITE}/talker_py"] == "link"
    assert kinds["share/talker_py/package.xml"] == "link"
    assert kinds[f"{EGG}/PKG-INFO"] == "file"


def test_switching_symlink_to_copy_leaves_no_links(tmp_path: Path) -> None:
    source = write_package(tmp_path / "src", "talker_py")
    build(source, tmp_path, symlink=True)
    ctx, _, _ = build(source, tmp_path)
    assert "link" not in tree(ctx.install_prefix).values()
    assert (source / "talker_py" / "words.py").read_text() == "WORD = 'hello v1'\n"


def test_cmdclass_package_takes_the_wheel_path_with_the_same_result(tmp_path: Path) -> None:
    fast_src = write_package(tmp_path / "a" / "src", "talker_py")
    slow_src = write_package(tmp_path / "b" / "src", "talker_py", cmdclass=True)
    fast, _, _ = build(fast_src, tmp_path / "a", environ=no_bytecode_env())
    slow, warnings, output = build(slow_src, tmp_path / "b", environ=no_bytecode_env())
    assert (slow.build_dir / "wheel").is_dir() and not (fast.build_dir / "wheel").exists()
    assert "bdist_wheel" in output  # the real PEP 517 build ran
    assert "SetuptoolsDeprecationWarning" not in output
    assert warnings == []
    fast_tree, slow_tree = tree(fast.install_prefix), tree(slow.install_prefix)
    assert fast_tree == slow_tree
    assert any(rel.endswith(".pyc") for rel in slow_tree)
    for rel, kind in fast_tree.items():
        if kind == "file" and not rel.endswith(".pyc"):  # a .pyc embeds its source's mtime
            assert (fast.install_prefix / rel).read_bytes() == \
                (slow.install_prefix / rel).read_bytes(), rel
    assert run_script(slow.install_prefix, slow.install_prefix / "lib/talker_py/talker") == \
        "hello v1\n"
    assert sorted(p.name for p in slow_src.iterdir()) == sorted(p.name for p in fast_src.iterdir())


def test_cmdclass_package_with_symlink_install_links_verbatim_copies(tmp_path: Path) -> None:
    source = write_package(tmp_path / "src", "talker_py", cmdclass=True)
    ctx, warnings, _ = build(source, tmp_path, symlink=True)
    kinds = tree(ctx.install_prefix)
    assert kinds["share/talker_py/launch/talk.launch.py"] == "link"
    assert kinds[f"{SITE}/talker_py/words.py"] == "link"
    assert len(warnings) == 1 and "cmdclass overrides build_py" in warnings[0]
    (source / "talker_py" / "words.py").write_text("WORD = 'hello v2'\n")
    prefix = ctx.install_prefix
    assert run_script(prefix, prefix / "lib/talker_py/talker") == "hello v2\n"


def test_broken_setup_py_fails_with_the_real_build_error(tmp_path: Path) -> None:
    source = write_package(tmp_path / "src", "talker_py")
    (source / "setup.py").write_text("import not_a_module_anywhere\n")
    with pytest.raises(StepFailed) as info:
        build(source, tmp_path)
    assert info.value.command[1].endswith("pep517_hook.py")
    assert info.value.cwd == source
