"""Installing into a stage prefix from a setup() plan or a wheel (plans written by hand)."""

from __future__ import annotations

import base64
import hashlib
import os
import subprocess
import sys
import zipfile
from pathlib import Path, PurePosixPath

import pytest

from wsbuild.build_types import StepFailed
from wsbuild.build_types.pybuild.install import (
    InstallTarget,
    StageWriter,
    install_plan,
    install_wheel,
    link_verbatim_copies,
    package_links,
    python_version_of,
    scripts_relpath,
)
from wsbuild.build_types.pybuild.setup_py import DataFiles, ModuleFile, SetupPlan

SITE = PurePosixPath("lib/python3.11/site-packages")


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def target(tmp_path: Path, *, symlink: bool = False, scripts: str = "lib/demo") -> InstallTarget:
    stage = tmp_path / "install" / ".stage"
    stage.mkdir(parents=True, exist_ok=True)
    return InstallTarget(stage_prefix=stage, install_prefix=tmp_path / "install" / "demo",
                         site_packages=SITE, scripts_dir=PurePosixPath(scripts),
                         python_executable=sys.executable, symlink=symlink)


def demo_source(tmp_path: Path) -> tuple[Path, SetupPlan]:
    src = tmp_path / "src" / "demo"
    write(src / "demo" / "__init__.py", "")
    write(src / "demo" / "main.py", "def main():\n    print('demo main')\n")
    write(src / "demo" / "data" / "table.csv", "a,b\n")
    write(src / "launch" / "x.launch.py", "launch = 1\n")
    write(src / "tool.py", "#!/usr/bin/env python3 -u\nprint('tool')\n")
    egg = tmp_path / "build" / "demo" / "demo.egg-info"
    write(egg / "PKG-INFO", "Metadata-Version: 2.4\nName: demo\nVersion: 1.0\n")
    write(egg / "entry_points.txt", "[console_scripts]\nrun-demo = demo.main:main\n")
    plan = SetupPlan(
        name="demo", version="1.0",
        files=(ModuleFile(PurePosixPath("demo/__init__.py"), src / "demo/__init__.py", "demo"),
               ModuleFile(PurePosixPath("demo/data/table.csv"), src / "demo/data/table.csv",
                          "demo"),
               ModuleFile(PurePosixPath("demo/main.py"), src / "demo/main.py", "demo")),
        packages=(("demo", src / "demo"),),
        data_files=(DataFiles(PurePosixPath("share/demo/launch"), ("launch/x.launch.py",)),
                    DataFiles(PurePosixPath("share/demo/empty"), ())),
        scripts=(src / "tool.py",),
        egg_info_dir=egg, egg_info_basename="demo-1.0-py3.11.egg-info")
    return src, plan


def listing(root: Path) -> dict[str, str]:
    found = {}
    for path in sorted(root.rglob("*")):
        kind = "link" if path.is_symlink() else "dir" if path.is_dir() else "file"
        found[path.relative_to(root).as_posix()] = kind
    return found


def test_scripts_dir_expands_setup_cfg_variables(tmp_path: Path) -> None:
    prefix = tmp_path / "install" / "demo"
    kwargs = dict(install_prefix=prefix, dist_name="demo", python_version="3.11",
                  origin=Path("setup.cfg"))
    assert scripts_relpath(None, **kwargs) == PurePosixPath("bin")  # type: ignore[arg-type]
    assert scripts_relpath("$base/lib/demo", **kwargs) == PurePosixPath("lib/demo")  # type: ignore[arg-type]
    assert scripts_relpath("${prefix}/lib/$dist_name", **kwargs) == \
        PurePosixPath("lib/demo")  # type: ignore[arg-type]
    with pytest.raises(StepFailed, match="outside the install prefix"):
        scripts_relpath("lib/demo", **kwargs)  # type: ignore[arg-type]
    with pytest.raises(StepFailed, match=r"\$userbase"):
        scripts_relpath("$userbase/bin", **kwargs)  # type: ignore[arg-type]


def test_python_version_from_site_packages() -> None:
    assert python_version_of(PurePosixPath("lib/python3.12/site-packages")) == "3.12"


def test_writer_never_writes_through_a_symlink_into_the_source(tmp_path: Path) -> None:
    src = tmp_path / "src"
    write(src / "pkg" / "__init__.py", "")
    stage = tmp_path / "stage"
    writer = StageWriter(stage)
    writer.symlink(src / "pkg", PurePosixPath("site/pkg"))
    with pytest.raises(StepFailed, match="is a symlink"):
        writer.write(PurePosixPath("site/pkg/generated.py"), b"x")
    with pytest.raises(StepFailed, match="is a symlink"):
        StageWriter(stage).copy(src / "pkg" / "__init__.py", PurePosixPath("site/pkg/sub/a.py"))
    assert sorted(p.name for p in (src / "pkg").iterdir()) == ["__init__.py"]
    # replacing an existing link replaces the link, never the file it points to
    writer.write(PurePosixPath("site/pkg"), b"plain")
    assert (stage / "site" / "pkg").read_bytes() == b"plain"
    assert (src / "pkg" / "__init__.py").exists()


def test_copy_install_places_every_planned_file(tmp_path: Path) -> None:
    src, plan = demo_source(tmp_path)
    tgt = target(tmp_path)
    to_compile = install_plan(plan, source_dir=src, target=tgt, origin=src / "setup.py")
    stage = tgt.stage_prefix
    assert listing(stage) == {
        "lib": "dir", "lib/demo": "dir", "lib/demo/run-demo": "file", "lib/demo/tool.py": "file",
        "lib/python3.11": "dir", f"{SITE}": "dir", f"{SITE}/demo": "dir",
        f"{SITE}/demo/__init__.py": "file", f"{SITE}/demo/main.py": "file",
        f"{SITE}/demo/data": "dir", f"{SITE}/demo/data/table.csv": "file",
        f"{SITE}/demo-1.0-py3.11.egg-info": "dir",
        f"{SITE}/demo-1.0-py3.11.egg-info/PKG-INFO": "file",
        f"{SITE}/demo-1.0-py3.11.egg-info/entry_points.txt": "file",
        "share": "dir", "share/demo": "dir", "share/demo/launch": "dir",
        "share/demo/launch/x.launch.py": "file", "share/demo/empty": "dir",
    }
    assert to_compile == [stage / SITE / "demo/__init__.py", stage / SITE / "demo/main.py"]
    tool = (stage / "lib/demo/tool.py").read_text()
    assert tool == f"#!{sys.executable} -u\nprint('tool')\n"
    assert os.access(stage / "lib/demo/tool.py", os.X_OK)
    script = stage / "lib/demo/run-demo"
    assert script.read_text().startswith(f"#!{sys.executable}\n")
    env = dict(os.environ, PYTHONPATH=str(stage / SITE))
    assert subprocess.run([str(script)], env=env, capture_output=True, text=True,
                          check=True).stdout == "demo main\n"
    # copies keep the source's mtime, like distutils' copy_file
    assert (stage / SITE / "demo/main.py").stat().st_mtime == \
        (src / "demo/main.py").stat().st_mtime


def test_symlink_install_links_packages_and_data_files(tmp_path: Path) -> None:
    src, plan = demo_source(tmp_path)
    tgt = target(tmp_path, symlink=True)
    assert install_plan(plan, source_dir=src, target=tgt, origin=src / "setup.py") == []
    stage = tgt.stage_prefix
    assert os.readlink(stage / SITE / "demo") == str(src / "demo")
    assert os.readlink(stage / "share/demo/launch/x.launch.py") == str(src / "launch/x.launch.py")
    assert not (stage / "lib/demo/run-demo").is_symlink()
    # the shebang of tool.py needs rewriting, so it stays a copy
    assert not (stage / "lib/demo/tool.py").is_symlink()


def test_package_links_only_whole_natural_packages(tmp_path: Path) -> None:
    src = tmp_path / "src"
    plan = SetupPlan(name="x", version="1", packages=(
        ("a", src / "a"), ("a.b", src / "a" / "b"),
        ("c", src / "c"), ("c.d", src / "moved"),
    ), files=(
        ModuleFile(PurePosixPath("a/b/__init__.py"), src / "a/b/__init__.py", "a.b"),
        ModuleFile(PurePosixPath("c/d/__init__.py"), src / "moved/__init__.py", "c.d"),
    ))
    for directory in ("a/b", "c", "moved"):
        (src / directory).mkdir(parents=True)
    assert package_links(plan) == {"a": src / "a", "c.d": src / "moved"}


def test_missing_data_file_names_setup_py(tmp_path: Path) -> None:
    src, plan = demo_source(tmp_path)
    (src / "launch" / "x.launch.py").unlink()
    with pytest.raises(StepFailed, match=r"setup.py: data_files source 'launch/x.launch.py'"):
        install_plan(plan, source_dir=src, target=target(tmp_path), origin=src / "setup.py")


def make_wheel(path: Path, files: dict[str, bytes]) -> Path:
    def line(name: str, data: bytes) -> str:
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        return f"{name},sha256={digest},{len(data)}"

    record = "\n".join(line(n, d) for n, d in files.items()) + "\ndemo-1.0.dist-info/RECORD,,\n"
    with zipfile.ZipFile(path, "w") as whl:
        for name, data in files.items():
            whl.writestr(name, data)
        whl.writestr("demo-1.0.dist-info/RECORD", record)
    return path


WHEEL_FILES = {
    "demo/__init__.py": b"",
    "demo/main.py": b"def main():\n    print('demo main')\n",
    "demo/generated.py": b"GENERATED = True\n",
    "demo-1.0.data/data/share/demo/launch/x.launch.py": b"launch = 1\n",
    "demo-1.0.dist-info/METADATA": b"Metadata-Version: 2.1\nName: demo\nVersion: 1.0\n",
    "demo-1.0.dist-info/WHEEL": b"Wheel-Version: 1.0\nRoot-Is-Purelib: true\nTag: py3-none-any\n",
    "demo-1.0.dist-info/entry_points.txt": b"[console_scripts]\nrun-demo = demo.main:main\n",
}


def test_wheel_install_uses_scripts_dir_and_egg_info(tmp_path: Path) -> None:
    _, plan = demo_source(tmp_path)
    wheel = make_wheel(tmp_path / "demo-1.0-py3-none-any.whl", WHEEL_FILES)
    tgt = target(tmp_path)
    to_compile = install_wheel(wheel, target=tgt, egg_info=plan.egg_info_dir,
                               egg_info_basename=plan.egg_info_basename)
    stage = tgt.stage_prefix
    assert (stage / "share/demo/launch/x.launch.py").read_text() == "launch = 1\n"
    assert (stage / "lib/demo/run-demo").read_text().startswith(f"#!{sys.executable}\n")
    assert not (stage / SITE / "demo-1.0.dist-info").exists()
    assert (stage / SITE / "demo-1.0-py3.11.egg-info" / "PKG-INFO").is_file()
    assert [p.name for p in to_compile] == ["__init__.py", "generated.py", "main.py"]


def test_wheel_install_keeps_dist_info_without_egg_info(tmp_path: Path) -> None:
    wheel = make_wheel(tmp_path / "demo-1.0-py3-none-any.whl", WHEEL_FILES)
    tgt = target(tmp_path, scripts="bin")
    install_wheel(wheel, target=tgt)
    assert (tgt.stage_prefix / SITE / "demo-1.0.dist-info" / "METADATA").is_file()
    assert (tgt.stage_prefix / "bin" / "run-demo").is_file()


def test_verbatim_copies_become_links_after_a_wheel_install(tmp_path: Path) -> None:
    src, plan = demo_source(tmp_path)
    wheel = make_wheel(tmp_path / "demo-1.0-py3-none-any.whl", WHEEL_FILES)
    tgt = target(tmp_path, symlink=True)
    install_wheel(wheel, target=tgt)
    write(src / "demo" / "__init__.py", "# differs from the built copy\n")
    linked = link_verbatim_copies(plan, source_dir=src, target=tgt, origin=src / "setup.py")
    stage = tgt.stage_prefix
    assert linked == 2
    assert (stage / SITE / "demo/main.py").is_symlink()
    assert (stage / "share/demo/launch/x.launch.py").is_symlink()
    assert not (stage / SITE / "demo/__init__.py").is_symlink()
    assert not (stage / SITE / "demo/generated.py").is_symlink()
