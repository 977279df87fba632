"""Find package directories under the base paths and identify each one as a Package."""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import ManifestError, WorkspaceError
from wsbuild.workspace.memo import ManifestMemo
from wsbuild.workspace.model import Dependency, DepKind, Package
from wsbuild import inputs
from wsbuild.patterns import lazy

IGNORE_MARKERS = ("COLCON_IGNORE", "AMENT_IGNORE", "CATKIN_IGNORE")
_PYTHON_FILES = ("pyproject.toml", "setup.py", "setup.cfg")
_PROJECT_RE = lazy(r"^\s*project\s*\(\s*([A-Za-z0-9_.+-]+)", re.MULTILINE | re.IGNORECASE)
_FIND_PACKAGE_RE = lazy(r"find_package\s*\(\s*([A-Za-z0-9_.+-]+)", re.IGNORECASE)
_SETUP_NAME_RE = lazy(r"""\bname\s*=\s*['"]([^'"]+)['"]""")
#: names of packages without package.xml (plain CMake/Python): no path or shell syntax
_PLAIN_NAME_RE = lazy(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")

#: a third-party way to recognise a package directory that has no package.xml (an entry point
#: of group `wsbuild.package_identification`, build_types/plugins.py): called with the
#: directory and the names of its entries, the package it is, or None. What it reads it reads
#: through wsbuild/inputs.py (declared, as every read of a run that plans).
Identifier = Callable[[Path, frozenset[str]], "Package | None"]


def find_package_dirs(base_paths: Iterable[Path], skip: Collection[Path] = (),
                      identifiers: Sequence[Identifier] = (),
                      claimed: dict[str, Package] | None = None) -> list[Path]:
    """Crawl each base path; a directory that is a package is not descended into.

    Skips ignore-marked, hidden, virtualenv and conda directories, and `skip` (the workspace's
    own build/install/log). Symlinks are followed, each real directory visited once. A
    directory none of the built-in rules takes is offered to the `identifiers`; what one says
    it is goes into `claimed` (by path).
    """
    skip_real = {inputs.realpath(p) for p in skip}
    seen: set[str] = set()
    found: list[Path] = []
    claims = _Claims(identifiers, claimed if claimed is not None else {})
    for base in base_paths:
        _crawl(str(base), inputs.realpath(base), skip_real, seen, found, claims)
    return found


@dataclass(frozen=True, slots=True)
class _Claims:
    """The package identifiers, and the directories they have claimed so far."""

    identifiers: Sequence[Identifier]
    claimed: dict[str, Package]

    def claim(self, path: Path, names: frozenset[str]) -> Package | None:
        """What the first identifier that knows the directory says it is (checked)."""
        for identifier in self.identifiers:
            named = f"{getattr(identifier, '__module__', '?')}." \
                f"{getattr(identifier, '__qualname__', type(identifier).__name__)}"
            hint = ("an identifier returns a wsbuild.workspace.model.Package of the directory "
                    "it was given, or None; update or uninstall the distribution providing it")
            try:
                package = identifier(path, names)
            except Exception as exc:  # a broken plugin: one line, naming it
                raise WorkspaceError(f"the package identifier {named} failed on {path}: {exc}",
                                     hint=hint) from None
            if package is not None:
                if not isinstance(package, Package) or package.path != path:
                    raise WorkspaceError(
                        f"the package identifier {named} answered a "
                        f"{type(package).__name__} not of {path}", hint=hint)
                _checked_plain_name(package.name, path)
                self.claimed[str(path)] = package
                return package
        return None


def _crawl(path: str, real: str, skip: set[str], seen: set[str], found: list[Path],
           claims: _Claims) -> None:
    # `real` is tracked alongside `path` so that only symlinks cost a realpath() call
    if real in seen or real in skip:
        return
    seen.add(real)
    try:
        entries = inputs.scandir(path)
    except (FileNotFoundError, NotADirectoryError, PermissionError):
        return
    names = {e.name for e in entries}
    if any(m in names for m in IGNORE_MARKERS) or "pyvenv.cfg" in names or "conda-meta" in names:
        return
    if _looks_like_package(path, names) or (
            claims.identifiers and claims.claim(Path(path), frozenset(names)) is not None):
        found.append(Path(path))
        return
    for entry in sorted(entries, key=lambda e: e.name):
        if entry.name.startswith(".") or entry.name == "__pycache__":
            continue
        try:
            is_dir = entry.is_dir()  # follows symlinks
            is_link = is_dir and entry.is_symlink()
        except OSError:
            continue
        if is_dir:
            child_real = inputs.realpath(entry.path) if is_link else f"{real}/{entry.name}"
            _crawl(entry.path, child_real, skip, seen, found, claims)


def _looks_like_package(path: str, names: set[str]) -> bool:
    if "package.xml" in names or "CMakeLists.txt" in names:
        return True
    if "setup.py" in names or "setup.cfg" in names:
        return True
    if "pyproject.toml" in names:
        return _pyproject_name(Path(path) / "pyproject.toml") is not None
    return False


def expand_paths(patterns: Iterable[str], cwd: Path) -> list[Path]:
    """`--paths` entries: shell wildcards, each match being a package directory."""
    import glob  # lazy: off a run without --paths

    result: list[Path] = []
    for pattern in patterns:
        full = pattern if os.path.isabs(pattern) else str(cwd / pattern)
        matches = sorted(glob.glob(full)) or ([full] if os.path.isdir(full) else [])
        if not matches:
            raise WorkspaceError(
                f"--paths '{pattern}' matches no directory", hint="check the path or the wildcard"
            )
        result.extend(Path(m) for m in matches if os.path.isdir(m))
    return result


def identify_package(
    path: Path,
    *,
    environ: Mapping[str, str],
    known_build_types: Collection[str],
    warnings: list[str],
    memo: ManifestMemo | None = None,
    identifiers: Sequence[Identifier] = (),
    claimed: Mapping[str, Package] | None = None,
) -> Package | None:
    """Read one package directory: package.xml first, else what a third-party identifier
    says (`claimed` by the crawl already, or asked now), else CMake, else Python metadata."""
    manifest = path / "package.xml"
    if inputs.exists(manifest):
        key = memo.key(manifest, environ) if memo is not None else None
        remembered = memo.get(manifest, key) if memo is not None and key is not None else None
        if remembered is not None and remembered[0].build_type in known_build_types:
            warnings.extend(remembered[1])
            return remembered[0]
        from wsbuild.workspace.manifest import parse_manifest  # lazy: off the full no-op build

        own: list[str] = []
        package = parse_manifest(
            manifest, environ=environ, known_build_types=known_build_types, warnings=own
        )
        warnings.extend(own)
        if memo is not None and key is not None and package is not None:
            memo.put(manifest, key, package, own)
        return package
    if claimed is not None and str(path) in claimed:
        return claimed[str(path)]
    if identifiers:
        found = _Claims(identifiers, {}).claim(
            path, frozenset(e.name for e in inputs.scandir(path)))
        if found is not None:
            return found
    if (path / "CMakeLists.txt").exists():
        return _identify_cmake(path)
    if any((path / f).exists() for f in _PYTHON_FILES):
        return _identify_python(path)
    return None


def _identify_cmake(path: Path) -> Package:
    cmakelists = path / "CMakeLists.txt"
    text = cmakelists.read_text(errors="replace")
    match = _PROJECT_RE.search(text)
    if not match:
        raise ManifestError(
            "CMakeLists.txt has no project() call, so the package has no name",
            path=cmakelists,
            hint="add project(<name>) or a package.xml",
        )
    deps = tuple(
        Dependency(name, kind)
        for name in sorted(set(_FIND_PACKAGE_RE.findall(text)))
        for kind in (DepKind.BUILD, DepKind.BUILD_EXPORT)
    )
    # colcon-cmake turns find_package() calls into dependencies; outside the workspace
    # they are system packages, which the resolver does not insist on.
    return Package(
        name=_checked_plain_name(match.group(1), cmakelists),
        path=path,
        build_type="cmake",
        dependencies=deps,
    )


def _pyproject_name(pyproject: Path) -> str | None:
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib  # type: ignore[no-redef]
    try:
        data = tomllib.loads(pyproject.read_text())
    except (OSError, ValueError) as exc:
        raise ManifestError(f"cannot read pyproject.toml: {exc}", path=pyproject) from exc
    name = data.get("project", {}).get("name")
    return name if isinstance(name, str) else None


def _identify_python(path: Path) -> Package:
    name: str | None = None
    version = "0.0.0"
    pyproject = path / "pyproject.toml"
    if pyproject.exists():
        name = _pyproject_name(pyproject)
    setup_cfg = path / "setup.cfg"
    if name is None and setup_cfg.exists():
        import configparser  # (a package.xml-less Python package only: the memo holds the rest)

        parser = configparser.ConfigParser(interpolation=None)
        try:
            parser.read(setup_cfg)
        except configparser.Error as exc:
            raise ManifestError(f"cannot parse setup.cfg: {exc}", path=setup_cfg) from exc
        name = parser.get("metadata", "name", fallback=None)
        version = parser.get("metadata", "version", fallback=version)
    setup_py = path / "setup.py"
    if name is None and setup_py.exists():
        match = _SETUP_NAME_RE.search(setup_py.read_text(errors="replace"))
        name = match.group(1) if match else None
    if name is None:
        where = setup_py if setup_py.exists() else (setup_cfg if setup_cfg.exists() else pyproject)
        raise ManifestError(
            "cannot tell the Python package's name",
            path=where,
            hint="put name=... in setup.cfg [metadata] or pyproject.toml [project]",
        )
    marker = pyproject if pyproject.exists() else (setup_cfg if setup_cfg.exists() else setup_py)
    return Package(
        name=_checked_plain_name(name, marker), path=path, build_type="python", version=version
    )


def _checked_plain_name(name: str, source: Path) -> str:
    if not _PLAIN_NAME_RE.match(name):
        raise ManifestError(
            f"invalid package name {name!r}",
            path=source,
            hint="use letters, digits, '.', '_' and '-', starting with a letter or digit",
        )
    return name


def check_unique(packages: Iterable[Package]) -> dict[str, Package]:
    """Index by name; two packages with one name is an error naming both paths."""
    by_name: dict[str, Package] = {}
    for package in packages:
        other = by_name.get(package.name)
        if other is not None:
            first, second = sorted([str(other.path), str(package.path)])
            raise WorkspaceError(
                f"two packages are named '{package.name}': {first} and {second}",
                hint="rename one, or put a COLCON_IGNORE file in the one to leave out",
            )
        by_name[package.name] = package
    return by_name


@dataclass(frozen=True, slots=True)
class Discovery:
    """The packages of a workspace, indexed by name, with the warnings reading them raised."""

    packages: dict[str, Package]
    warnings: tuple[str, ...]


def discover_packages(
    workspace_dirs: Sequence[Path],
    *,
    base_paths: Sequence[Path],
    paths: Sequence[Path] = (),
    environ: Mapping[str, str],
    known_build_types: Collection[str],
    memo_file: Path | None = None,
    remember: bool = True,
    identifiers: Sequence[Identifier] = (),
) -> Discovery:
    """Find and identify every package; `paths` (explicit package dirs) win over crawling.

    `known_build_types` answers which `<build_type>` names exist (the build_types room's
    `KnownBuildTypes()`; the workspace room does not import the build types itself).
    `memo_file` remembers what each package.xml read gave (workspace/memo.py); without
    `remember` it is only read (a dry run writes nothing). `identifiers`: the third-party
    ways to recognise a package without package.xml (`Identifier`)."""
    claimed: dict[str, Package] = {}
    dirs = list(paths) if paths else find_package_dirs(base_paths, skip=workspace_dirs,
                                                       identifiers=identifiers, claimed=claimed)
    warnings: list[str] = []
    found = []
    memo = ManifestMemo.load(memo_file)
    for directory in dirs:
        package = identify_package(
            directory, environ=environ, known_build_types=known_build_types, warnings=warnings,
            memo=memo, identifiers=identifiers, claimed=claimed,
        )
        if package is not None:
            found.append(package)
    if remember and found:  # a workspace without packages gets no build/ for it
        memo.save()
    return Discovery(packages=check_unique(found), warnings=tuple(warnings))
