"""Writing a rendered package: the destination checked, the files written into a hidden staging
directory beside it and renamed into place once the generated package.xml parses, so a failure
leaves nothing behind."""

from __future__ import annotations

import os
import secrets
import shutil
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from wsbuild.create.templates import render_package
from wsbuild.create.validation import PackageCreateError, PackageRequest
from wsbuild.errors import ManifestError, TemplateError
from wsbuild.workspace.discover import find_package_dirs
from wsbuild.workspace.manifest import parse_manifest
from wsbuild.workspace.root import Workspace, find_workspace_root
from wsbuild.patterns import lazy


@dataclass(frozen=True, slots=True)
class CreatedPackage:
    """A package written to disk."""

    name: str
    path: Path
    build_type: str
    variants: tuple[str, ...]
    files: tuple[PurePosixPath, ...]
    notes: tuple[str, ...]


def create_package(request: PackageRequest, *, root: Path | None = None) -> CreatedPackage:
    """Validate, render, and write the package to `request.destination / request.name`.

    Raises PackageCreateError (bad input, the directory exists, the destination is inside
    another package or the workspace already has a package of that name) before writing
    anything, and removes whatever it wrote if a later step fails.
    """
    rendered = render_package(request, root=root)
    destination = Path(os.path.abspath(request.destination))
    target = destination / rendered.name
    _check_destination(destination, target, rendered.name)
    staging = _make_staging_dir(destination, rendered.name)
    try:
        for relative, content in rendered.files:
            path = staging.joinpath(*relative.parts)
            path.parent.mkdir(parents=True, exist_ok=True)
            with open(path, "w", encoding="utf-8", newline="") as stream:
                stream.write(content)
        _check_manifest(staging / "package.xml", rendered.build_type)
        if os.path.lexists(target):
            raise PackageCreateError("the directory already exists; nothing was written",
                                     path=target, hint="remove it or choose another name")
        os.rename(staging, target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return CreatedPackage(
        name=rendered.name, path=target, build_type=rendered.build_type,
        variants=rendered.variants, files=tuple(path for path, _ in rendered.files),
        notes=rendered.notes)


def _check_destination(destination: Path, target: Path, name: str) -> None:
    if not destination.is_dir():
        raise PackageCreateError("the destination directory does not exist", path=destination,
                                 hint="create it first or pass another --destination-directory")
    if os.path.lexists(target):
        raise PackageCreateError("the directory already exists; nothing was written", path=target,
                                 hint="remove it, or choose another name or "
                                      "--destination-directory")
    for directory in (destination, *destination.parents):
        if (directory / "package.xml").is_file():
            raise PackageCreateError(
                "the destination is inside the package " + repr(directory.name),
                path=directory / "package.xml",
                hint="packages inside packages are not found by wsbuild or colcon; "
                     "create it beside that package instead")
    existing = _workspace_packages(destination).get(name)
    if existing is not None:
        raise PackageCreateError(f"the workspace already has a package named {name!r}",
                                 path=existing / "package.xml",
                                 hint="package names must be unique in a workspace")


_MANIFEST_NAME = lazy(rb"<name>\s*([^<\s]+)\s*</name>")


def _workspace_packages(destination: Path) -> dict[str, Path]:
    """Package name → directory of the ROS packages under the workspace's src/, if
    `destination` is in one (names read cheaply; broken manifests are skipped)."""
    workspace = Workspace.at(find_workspace_root(destination))
    root = workspace.root
    src = root / "src"
    if not src.is_dir() or not (destination == src or src in destination.parents):
        return {}
    found: dict[str, Path] = {}
    skip = [workspace.build_base, workspace.install_base, workspace.log_base]
    for directory in find_package_dirs([src], skip):
        try:
            match = _MANIFEST_NAME.search((directory / "package.xml").read_bytes())
        except OSError:
            continue
        if match:
            found.setdefault(match.group(1).decode("utf-8", "replace"), directory)
    return found


def _make_staging_dir(destination: Path, name: str) -> Path:
    # os.mkdir (unlike mkdtemp) applies the umask, so the renamed package gets normal modes.
    for _ in range(100):
        staging = destination / f".{name}.wsbuild-create-{secrets.token_hex(4)}"
        try:
            os.mkdir(staging)
        except FileExistsError:
            continue
        except OSError as exc:
            raise PackageCreateError(f"cannot write into the destination: {exc.strerror}",
                                     path=destination) from None
        return staging
    raise PackageCreateError("cannot create a temporary directory", path=destination)


def _check_manifest(path: Path, build_type: str) -> None:
    warnings: list[str] = []
    try:
        parse_manifest(path, environ={}, known_build_types=(build_type,), warnings=warnings)
    except ManifestError as exc:
        raise PackageCreateError(f"these options give an invalid package.xml: {exc.message}",
                                 hint=exc.hint) from None
    if warnings:
        raise TemplateError(f"the generated package.xml has warnings: {warnings[0]}", path=path)
