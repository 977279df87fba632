"""Installing a Python package into a staging prefix, from a setup() plan or from a wheel."""

from __future__ import annotations

import filecmp
import os
import re
import shutil
import sys
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from wsbuild.build_types import StepFailed
from wsbuild.build_types.pybuild.setup_py import ModuleFile, SetupPlan
from wsbuild.patterns import lazy

# distutils' build_scripts rewrites a shebang naming python to the building interpreter
_PYTHON_SHEBANG = lazy(rb"^#!.*python[0-9.]*([ \t].*)?$")
_CONFIG_VAR = lazy(r"\$(?:\{(\w+)\}|(\w+))")
_METADATA_SUFFIXES = (".egg-info", ".dist-info")


@dataclass(frozen=True, slots=True)
class InstallTarget:
    """Where one package's files go: written under `stage_prefix`, used from `install_prefix`."""

    stage_prefix: Path
    install_prefix: Path
    site_packages: PurePosixPath  # relative to the prefix
    scripts_dir: PurePosixPath  # relative to the prefix
    python_executable: str
    symlink: bool = False

    def staged(self, relpath: PurePosixPath | str) -> Path:
        return self.stage_prefix / relpath

    def final(self, staged: Path) -> Path:
        return self.install_prefix / staged.relative_to(self.stage_prefix)


class StageWriter:
    """Creates files below one root and never writes through a symlink (which could point
    into the source directory after a symlink install)."""

    def __init__(self, root: Path) -> None:
        self.root = root
        root.mkdir(parents=True, exist_ok=True)
        self._real_dirs: set[Path] = {root}

    def directory(self, relpath: PurePosixPath | str) -> Path:
        """Create `root/relpath` as real directories; refuse to pass through a symlink."""
        path = self.root
        for part in PurePosixPath(relpath).parts:
            path = path / part
            if path in self._real_dirs:
                continue
            if path.is_symlink():
                raise StepFailed(f"refusing to install into {path}: it is a symlink to "
                                 f"{os.readlink(path)} (two installed paths overlap)")
            path.mkdir(exist_ok=True)
            self._real_dirs.add(path)
        return path

    def _prepare(self, relpath: PurePosixPath) -> Path:
        dest = self.directory(relpath.parent) / relpath.name
        if dest.is_symlink() or dest.is_file():
            dest.unlink()  # only the link itself, never its target
        elif dest.is_dir():
            shutil.rmtree(dest)
        return dest

    def copy(self, source: Path, relpath: PurePosixPath) -> Path:
        dest = self._prepare(relpath)
        shutil.copy2(source, dest)  # keeps mtimes, like distutils' copy_file
        return dest

    def symlink(self, source: Path, relpath: PurePosixPath) -> Path:
        dest = self._prepare(relpath)
        dest.symlink_to(source)
        return dest

    def write(self, relpath: PurePosixPath, data: bytes, *, executable: bool = False) -> Path:
        dest = self._prepare(relpath)
        dest.write_bytes(data)
        if executable:
            dest.chmod(0o777 & ~_umask() | 0o111)  # as installer does
        return dest


def scripts_relpath(option: str | None, *, install_prefix: Path, dist_name: str,
                    python_version: str, origin: Path) -> PurePosixPath:
    """The scripts directory relative to the prefix from setup.cfg's value, `bin` if unset.

    Expands distutils' variables (`$base/lib/<pkg>`) the way `setup.py install --prefix`
    would. `origin` names the file the value comes from, for error messages.
    """
    if not option:
        return PurePosixPath("bin")
    values = {
        "base": str(install_prefix), "platbase": str(install_prefix),
        "prefix": str(install_prefix), "exec_prefix": str(install_prefix),
        "installed_base": str(install_prefix), "installed_platbase": str(install_prefix),
        "dist_name": dist_name, "py_version_short": python_version,
        "py_version_nodot": python_version.replace(".", ""), "abiflags": "",
    }

    def expand(match: re.Match[str]) -> str:
        name = match.group(1) or match.group(2)
        if name not in values:
            raise StepFailed(f"{origin}: install_scripts={option} uses ${name}, which wsbuild "
                             "does not expand (use $base)")
        return values[name]

    expanded = Path(os.path.normpath(_CONFIG_VAR.sub(expand, os.path.expanduser(option))))
    if not expanded.is_absolute() or not expanded.is_relative_to(install_prefix):
        raise StepFailed(f"{origin}: install_scripts={option} is outside the install prefix "
                         "(start it with $base/)")
    return PurePosixPath(expanded.relative_to(install_prefix).as_posix())


def python_version_of(site_packages: PurePosixPath) -> str:
    """`3.11` from `lib/python3.11/site-packages`."""
    match = re.search(r"python(\d+\.\d+)", str(site_packages))
    return match.group(1) if match else f"{sys.version_info[0]}.{sys.version_info[1]}"


def install_plan(plan: SetupPlan, *, source_dir: Path, target: InstallTarget,
                 origin: Path) -> list[Path]:
    """Install what setuptools planned (the fast path); returns the staged `.py` files to
    byte-compile. `origin` is the setup.py (or pyproject.toml) named in error messages."""
    assert plan.egg_info_dir is not None and plan.egg_info_basename is not None
    writer = StageWriter(target.stage_prefix)
    site = target.site_packages
    to_compile: list[Path] = []
    linked = package_links(plan) if target.symlink else {}
    for package, package_dir in sorted(linked.items()):
        writer.symlink(package_dir, site / package.replace(".", "/"))
    for module in plan.files:
        if target.symlink:
            if not _covered(module.package, linked):
                writer.symlink(module.source, site / module.dest)
            continue
        staged = writer.copy(_existing(module.source, origin), site / module.dest)
        if staged.suffix == ".py":
            to_compile.append(staged)
    install_data_files(plan, source_dir=source_dir, writer=writer, symlink=target.symlink,
                       origin=origin)
    for script in plan.scripts:
        _install_script(_existing(script, origin), writer, target)
    entry_points = plan.egg_info_dir / "entry_points.txt"
    if entry_points.is_file():
        write_console_scripts(entry_points.read_text(encoding="utf-8"), writer, target)
    copy_tree(plan.egg_info_dir, site / plan.egg_info_basename, writer)
    return to_compile


def install_data_files(plan: SetupPlan, *, source_dir: Path, writer: StageWriter,
                       symlink: bool, origin: Path) -> None:
    """`data_files` like distutils' install_data (an empty list still creates the directory);
    per-file symlinks to the source in a symlink install."""
    for source, relpath in data_file_mapping(plan, source_dir=source_dir, origin=origin):
        if symlink:
            writer.symlink(source, relpath)
        else:
            writer.copy(source, relpath)
    for entry in plan.data_files:
        if not entry.sources:
            writer.directory(entry.directory)


def data_file_mapping(plan: SetupPlan, *, source_dir: Path,
                      origin: Path) -> list[tuple[Path, PurePosixPath]]:
    """(source file, path relative to the prefix) for every `data_files` source."""
    mapping = []
    for entry in plan.data_files:
        if entry.directory.is_absolute() or ".." in entry.directory.parts:
            raise StepFailed(f"{origin}: data_files directory '{entry.directory}' must be "
                             "relative to the install prefix")
        for name in entry.sources:
            source = source_dir / name
            if not source.is_file():
                raise StepFailed(f"{origin}: data_files source '{name}' is not a file "
                                 f"(looked for {source})")
            mapping.append((source, entry.directory / source.name))
    return mapping


def package_links(plan: SetupPlan) -> dict[str, Path]:
    """Packages that a symlink install can link as whole directories: those whose
    subpackages and files all sit at their natural place below the package's directory."""
    package_dirs = dict(plan.packages)
    linked: dict[str, Path] = {}
    for package in sorted(package_dirs, key=lambda p: (p.count("."), p)):
        if _covered(package, linked):
            continue
        if _is_natural(package, package_dirs, plan.files):
            linked[package] = package_dirs[package]
    return linked


def _is_natural(package: str, package_dirs: Mapping[str, Path],
                files: Iterable[ModuleFile]) -> bool:
    root = Path(os.path.normpath(package_dirs[package]))
    if not root.is_dir():
        return False
    for other, other_dir in package_dirs.items():
        if other.startswith(package + "."):
            natural = root.joinpath(*other[len(package) + 1:].split("."))
            if Path(os.path.normpath(other_dir)) != natural:
                return False
    prefix = PurePosixPath(*package.split("."))
    for module in files:
        if _covered(module.package, {package: root}):
            natural = root / module.dest.relative_to(prefix)
            if Path(os.path.normpath(module.source)) != natural:
                return False
    return True


def _covered(package: str, linked: Mapping[str, Path]) -> bool:
    return any(package == p or package.startswith(p + ".") for p in linked)


def _existing(path: Path, origin: Path) -> Path:
    if not path.is_file():
        raise StepFailed(f"{origin}: {path} is listed for installation but does not exist")
    return path


def _install_script(source: Path, writer: StageWriter, target: InstallTarget) -> None:
    # `scripts=`: copied with the shebang pointing at the building interpreter; linked in a
    # symlink install when no shebang needs rewriting (so edits take effect)
    relpath = target.scripts_dir / source.name
    data = source.read_bytes()
    first, newline, rest = data.partition(b"\n")
    match = _PYTHON_SHEBANG.match(first)
    if target.symlink and not match:
        writer.symlink(source, relpath)
        return
    if match:
        data = b"#!" + target.python_executable.encode() + (match.group(1) or b"") + b"\n" + rest
    writer.write(relpath, data, executable=True)


def write_console_scripts(entry_points: str, writer: StageWriter, target: InstallTarget) -> None:
    """console_scripts and gui_scripts as installer (and pip) write them."""
    from installer.scripts import Script
    from installer.utils import parse_entrypoints

    for name, module, attr, section in parse_entrypoints(entry_points):
        script_name, data = Script(name, module, attr, section).generate(
            target.python_executable, "posix")
        writer.write(target.scripts_dir / script_name, data, executable=True)


def copy_tree(source: Path, relpath: PurePosixPath, writer: StageWriter) -> None:
    for root, dirs, files in os.walk(source):
        dirs.sort()
        rel = PurePosixPath(Path(root).relative_to(source).as_posix())
        for name in sorted(files):
            writer.copy(Path(root) / name, relpath / rel / name)


def install_wheel(wheel: Path, *, target: InstallTarget, egg_info: Path | None = None,
                  egg_info_basename: str | None = None) -> list[Path]:
    """Install a wheel with `installer`; returns the staged `.py` files to byte-compile.

    With `egg_info` (setuptools builds), the wheel's `.dist-info` is replaced by setuptools'
    `.egg-info`, so the tree equals the fast path's and colcon's.
    """
    from installer import install
    from installer.destinations import SchemeDictionaryDestination
    from installer.sources import WheelFile

    site = target.staged(target.site_packages)
    with WheelFile.open(wheel) as source:
        dist_info = source.dist_info_dir
        scheme = {
            "purelib": str(site), "platlib": str(site),
            "headers": str(target.staged(PurePosixPath("include", source.distribution))),
            "scripts": str(target.staged(target.scripts_dir)),
            "data": str(target.stage_prefix),
        }
        destination = SchemeDictionaryDestination(
            scheme, interpreter=target.python_executable, script_kind="posix")
        install(source, destination, additional_metadata={})
    if egg_info is not None and egg_info_basename is not None:
        shutil.rmtree(site / dist_info)
        writer = StageWriter(target.stage_prefix)
        copy_tree(egg_info, target.site_packages / egg_info_basename, writer)
    return sorted(
        path for path in site.rglob("*.py")
        if not path.is_symlink()
        and not any(part.endswith(_METADATA_SUFFIXES) for part in path.relative_to(site).parts)
    )


def link_verbatim_copies(plan: SetupPlan, *, source_dir: Path, target: InstallTarget,
                         origin: Path) -> int:
    """After a wheel install with --symlink-install: replace every installed file that is a
    verbatim copy of a source file by a symlink to it. Returns how many were linked."""
    pairs = [(m.source, target.site_packages / m.dest) for m in plan.files]
    pairs += data_file_mapping(plan, source_dir=source_dir, origin=origin)
    writer = StageWriter(target.stage_prefix)
    linked = 0
    for source, relpath in pairs:
        staged = target.staged(relpath)
        if staged.is_file() and not staged.is_symlink() and source.is_file() \
                and filecmp.cmp(source, staged, shallow=False):
            writer.symlink(source, relpath)
            linked += 1
    return linked


def _umask() -> int:
    # /proc avoids os.umask's set-and-restore, which races with other threads creating files
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
