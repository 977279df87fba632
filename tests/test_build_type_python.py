"""The python build type: setup.py, setup.cfg and pyproject.toml packages with real backends."""

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
PY = f"{sys.version_info[0]}.{sys.version_info[1]}"


def runner(output: list[str]):
    def run(command: Sequence[str], *, cwd: Path, env: Mapping[str, str] | None = None) -> None:
        completed = subprocess.run(list(command), cwd=cwd, env=env, capture_output=True,
                                   text=True)
        output.append(completed.stdout + completed.stderr)
        if completed.returncode:
            raise StepFailed(f"{command[0]} failed", command=command, cwd=cwd,
                             returncode=completed.returncode)
    return run


def build(source: Path, workspace: Path, *, symlink: bool = False,
          output: list[str] | None = None) -> tuple[PackageContext, list[str], str]:
    """Run every step of the python build type; the stage then replaces the prefix."""
    name = source.name
    stage = workspace / "install" / f".{name}.stage"
    shutil.rmtree(stage, ignore_errors=True)
    stage.mkdir(parents=True)
    warnings: list[str] = []
    output = [] if output is None else output
    ctx = PackageContext(
        package=Package(name=name, path=source, build_type="python"),
        build_dir=workspace / "build" / name, install_prefix=workspace / "install" / name,
        stage_prefix=stage,
        options=BuildOptions(symlink_install=symlink, python_executable=sys.executable),
        environ=dict(os.environ), run=runner(output), warn=warnings.append)
    ctx.build_dir.mkdir(parents=True, exist_ok=True)
    for step in get_build_type("python").steps(ctx):
        step.action(ctx)
    shutil.rmtree(ctx.install_prefix, ignore_errors=True)
    stage.rename(ctx.install_prefix)
    log = ctx.build_dir / SETUP_LOG
    return ctx, warnings, (log.read_text() if log.exists() else "") + "".join(output)


def files(prefix: Path) -> set[str]:
    return {p.relative_to(prefix).as_posix() for p in prefix.rglob("*")
            if p.is_file() or p.is_symlink()}


def python_in(prefix: Path, code: str) -> str:
    env = dict(os.environ, PYTHONPATH=str(prefix / SITE))
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True).stdout


def run_script(prefix: Path, script: str) -> str:
    env = dict(os.environ, PYTHONPATH=str(prefix / SITE))
    return subprocess.run([str(prefix / script)], env=env, capture_output=True, text=True,
                          check=True).stdout


@pytest.fixture(scope="module", autouse=True)
def _helpers() -> Iterator[None]:
    yield
    shutdown_helpers()


def test_py_modules_package_installs_modules_and_bin_scripts(tmp_path: Path) -> None:
    source = tmp_path / "src" / "single_mod"
    source.mkdir(parents=True)
    (source / "single_mod.py").write_text("def main():\n    print('single')\n")
    (source / "setup.py").write_text(
        "from setuptools import setup\n"
        "setup(name='single_mod', version='1.0', py_modules=['single_mod'],\n"
        "      entry_points={'console_scripts': ['single = single_mod:main']})\n")
    ctx, warnings, output = build(source, tmp_path)
    assert files(ctx.install_prefix) >= {f"{SITE}/single_mod.py", "bin/single",
                                         f"{SITE}/single_mod-1.0-py{PY}.egg-info/PKG-INFO"}
    assert run_script(ctx.install_prefix, "bin/single") == "single\n"
    assert warnings == [] and "Warning" not in output


def test_src_layout_package_with_package_data(tmp_path: Path) -> None:
    source = tmp_path / "src" / "srclayout"
    (source / "src" / "srclayout" / "data").mkdir(parents=True)
    (source / "src" / "srclayout" / "__init__.py").write_text("VALUE = 'src layout'\n")
    (source / "src" / "srclayout" / "data" / "table.csv").write_text("a,b\n")
    (source / "setup.py").write_text(
        "from setuptools import setup\n"
        "setup(name='srclayout', version='2.0', packages=['srclayout'],\n"
        "      package_dir={'': 'src'}, package_data={'srclayout': ['data/*.csv']})\n")
    ctx, _, _ = build(source, tmp_path)
    assert files(ctx.install_prefix) >= {f"{SITE}/srclayout/__init__.py",
                                         f"{SITE}/srclayout/data/table.csv"}
    assert python_in(ctx.install_prefix, "import srclayout; print(srclayout.VALUE)") == \
        "src layout\n"
    assert not (source / "src" / "srclayout.egg-info").exists()

    linked, _, _ = build(source, tmp_path, symlink=True)
    link = linked.install_prefix / SITE / "srclayout"
    assert link.is_symlink() and link.resolve() == (source / "src" / "srclayout").resolve()
    (source / "src" / "srclayout" / "__init__.py").write_text("VALUE = 'edited'\n")
    assert python_in(linked.install_prefix, "import srclayout; print(srclayout.VALUE)") == \
        "edited\n"


def test_renamed_subpackage_is_linked_file_by_file(tmp_path: Path) -> None:
    source = tmp_path / "src" / "renamed"
    (source / "top").mkdir(parents=True)
    (source / "elsewhere").mkdir()
    (source / "top" / "__init__.py").write_text("")
    (source / "elsewhere" / "__init__.py").write_text("WHERE = 'elsewhere'\n")
    (source / "setup.py").write_text(
        "from setuptools import setup\n"
        "setup(name='renamed', version='1', packages=['top', 'top.sub'],\n"
        "      package_dir={'top.sub': 'elsewhere'})\n")
    ctx, _, _ = build(source, tmp_path, symlink=True)
    site = ctx.install_prefix / SITE
    assert (site / "top").is_dir() and not (site / "top").is_symlink()
    assert (site / "top" / "__init__.py").is_symlink()
    assert (site / "top" / "sub").is_symlink()
    assert python_in(ctx.install_prefix, "import top.sub; print(top.sub.WHERE)") == "elsewhere\n"
    assert (source / "top").is_dir() and sorted(os.listdir(source / "top")) == ["__init__.py"]


def test_pyproject_only_setuptools_package_takes_the_fast_path(tmp_path: Path) -> None:
    source = tmp_path / "src" / "modern"
    (source / "modern").mkdir(parents=True)
    (source / "modern" / "__init__.py").write_text("def main():\n    print('modern')\n")
    (source / "pyproject.toml").write_text(
        '[build-system]\nrequires = ["setuptools>=61"]\n'
        'build-backend = "setuptools.build_meta"\n\n'
        '[project]\nname = "modern"\nversion = "3.1"\ndependencies = ["packaging"]\n\n'
        '[project.scripts]\nmodern = "modern:main"\n\n'
        '[tool.setuptools]\npackages = ["modern"]\n')
    ctx, warnings, output = build(source, tmp_path)
    assert not (ctx.build_dir / "wheel").exists()
    assert files(ctx.install_prefix) >= {f"{SITE}/modern/__init__.py", "bin/modern",
                                         f"{SITE}/modern-3.1-py{PY}.egg-info/requires.txt"}
    assert run_script(ctx.install_prefix, "bin/modern") == "modern\n"
    assert python_in(ctx.install_prefix,
                     "from importlib.metadata import version; print(version('modern'))") == \
        "3.1\n"
    assert warnings == [] and "Warning" not in output
    assert sorted(p.name for p in source.iterdir()) == ["modern", "pyproject.toml"]


IN_TREE_BACKEND = '''\
"""A minimal PEP 517 backend that is not setuptools."""
import base64, hashlib, os, zipfile

NAME, VERSION = "plain_backend_pkg", "0.9"


def _record_line(path, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{path},sha256={digest},{len(data)}"


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    dist_info = f"{NAME}-{VERSION}.dist-info"
    files = {
        f"{NAME}.py": b"def main():\\n    print('plain backend')\\n",
        f"{dist_info}/METADATA": f"Metadata-Version: 2.1\\nName: {NAME}\\nVersion: {VERSION}\\n".encode(),
        f"{dist_info}/WHEEL": b"Wheel-Version: 1.0\\nGenerator: test\\nRoot-Is-Purelib: true\\nTag: py3-none-any\\n",
        f"{dist_info}/entry_points.txt": f"[console_scripts]\\nplain = {NAME}:main\\n".encode(),
        f"{NAME}-{VERSION}.data/data/share/{NAME}/notes.txt": b"notes\\n",
    }
    record = "\\n".join(_record_line(p, d) for p, d in files.items())
    record += f"\\n{dist_info}/RECORD,,\\n"
    name = f"{NAME}-{VERSION}-py3-none-any.whl"
    with zipfile.ZipFile(os.path.join(wheel_directory, name), "w") as whl:
        for path, data in files.items():
            whl.writestr(path, data)
        whl.writestr(f"{dist_info}/RECORD", record)
    return name
'''


def test_pyproject_with_other_backend_is_built_through_pep517(tmp_path: Path) -> None:
    source = tmp_path / "src" / "plain_backend_pkg"
    (source / "backend").mkdir(parents=True)
    (source / "backend" / "plain_backend.py").write_text(IN_TREE_BACKEND)
    (source / "pyproject.toml").write_text(
        '[build-system]\nrequires = []\nbuild-backend = "plain_backend"\n'
        'backend-path = ["backend"]\n')
    ctx, warnings, _ = build(source, tmp_path)
    installed = files(ctx.install_prefix)
    assert {f"{SITE}/plain_backend_pkg.py", "bin/plain", "share/plain_backend_pkg/notes.txt",
            f"{SITE}/plain_backend_pkg-0.9.dist-info/METADATA"} <= installed
    assert run_script(ctx.install_prefix, "bin/plain") == "plain backend\n"
    assert (ctx.install_prefix / "bin/plain").read_text().startswith(f"#!{sys.executable}\n")
    assert warnings == []


def test_missing_backend_fails_with_a_reproducible_command(tmp_path: Path) -> None:
    source = tmp_path / "src" / "nobackend"
    source.mkdir(parents=True)
    (source / "pyproject.toml").write_text(
        '[build-system]\nrequires = ["not-installed-backend"]\n'
        'build-backend = "not_installed_backend"\n')
    output: list[str] = []
    with pytest.raises(StepFailed) as info:
        build(source, tmp_path, output=output)
    assert info.value.command[2] == "not_installed_backend"
    assert info.value.cwd == source
    assert f"{sys.executable} -m pip install not-installed-backend" in output[-1]


def test_directory_without_project_files_fails(tmp_path: Path) -> None:
    source = tmp_path / "src" / "empty"
    source.mkdir(parents=True)
    with pytest.raises(StepFailed, match="no setup.py, setup.cfg or pyproject.toml"):
        build(source, tmp_path)


def test_setup_cfg_scripts_dir_and_declarative_config(tmp_path: Path) -> None:
    source = tmp_path / "src" / "declared"
    (source / "declared").mkdir(parents=True)
    (source / "declared" / "__init__.py").write_text("def main():\n    print('declared')\n")
    (source / "setup.cfg").write_text(
        "[metadata]\nname = declared\nversion = 4.2\n\n"
        "[options]\npackages = find:\n\n"
        "[options.entry_points]\nconsole_scripts =\n    declared = declared:main\n\n"
        "[options.data_files]\nshare/declared = setup.cfg\n\n"
        "[install]\ninstall_scripts = $base/lib/declared\n")
    (source / "setup.py").write_text("from setuptools import setup\nsetup()\n")
    ctx, _, _ = build(source, tmp_path)
    assert files(ctx.install_prefix) >= {"lib/declared/declared", "share/declared/setup.cfg",
                                         f"{SITE}/declared/__init__.py"}
    assert run_script(ctx.install_prefix, "lib/declared/declared") == "declared\n"
