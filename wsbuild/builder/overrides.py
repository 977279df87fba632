"""Overrides: selected packages that an underlay already provides while other underlay packages
use them. Those users were built against the underlay's version and may now meet the overlay's
at run time (two versions of one package: API and ABI must match), as colcon warns."""

from __future__ import annotations

import os
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import SelectionError
from wsbuild import inputs

#: package.xml tags whose package a built package needs at its run time or in its interface
_DEPEND_TAGS = frozenset({"depend", "build_depend", "build_export_depend",
                          "buildtool_export_depend", "exec_depend", "run_depend"})
_AMENT_INDEX = Path("share", "ament_index", "resource_index", "packages")
_COLCON_INDEX = Path("share", "colcon-core", "packages")


@dataclass(frozen=True, slots=True)
class Override:
    """A workspace package that overrides one of the same name in an underlay."""

    package: str
    #: the underlay prefix that provides it (the first one on the path)
    prefix: Path
    #: underlay packages that depend on it
    users: tuple[str, ...]


def _listdir(path: Path) -> list[str]:
    try:
        return sorted(n for n in inputs.listdir(path) if not n.startswith("."))
    except OSError:
        return []


def _inside(real: str, own: str) -> bool:
    return real == own or real.startswith(own + os.sep)


def underlay_packages(environ: Mapping[str, str], own_install_base: Path) -> dict[str, Path]:
    """package -> the first underlay prefix providing it: the ament index and colcon's package
    index of every AMENT_PREFIX_PATH entry, and the installs on COLCON_PREFIX_PATH; this
    workspace's own install is no underlay."""
    own = os.path.realpath(own_install_base)
    prefixes: list[Path] = []
    for entry in environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if entry:
            prefixes.append(Path(entry))
    for entry in environ.get("COLCON_PREFIX_PATH", "").split(os.pathsep):
        if not entry:
            continue
        base = Path(entry)
        if _inside(inputs.realpath(base), own):
            continue
        # a merged install base is one prefix; an isolated one has one per package
        prefixes += [base] + [base / name for name in _listdir(base)
                              if inputs.is_file(base / name / _COLCON_INDEX / name)]
    provided: dict[str, Path] = {}
    for prefix in prefixes:
        if _inside(inputs.realpath(prefix), own):
            continue
        for name in (*_listdir(prefix / _AMENT_INDEX), *_listdir(prefix / _COLCON_INDEX)):
            provided.setdefault(name, prefix)
    return provided


def _dependencies(name: str, prefix: Path) -> set[str]:
    """What an installed package depends on: colcon's index file (its run dependencies), else
    the package.xml it installed."""
    try:
        text = (prefix / _COLCON_INDEX / name).read_text()
        return {d for d in text.strip().split(os.pathsep) if d}
    except OSError:
        pass
    from lxml import etree

    try:
        root = etree.parse(str(prefix / "share" / name / "package.xml")).getroot()
    except (OSError, etree.XMLSyntaxError):
        return set()
    return {element.text.strip() for element in root
            if element.tag in _DEPEND_TAGS and element.text and element.text.strip()}


def find_overrides(selected: Iterable[str], workspace: Iterable[str],
                   environ: Mapping[str, str], own_install_base: Path) -> list[Override]:
    """The `selected` packages an underlay provides and other underlay packages depend on.
    Users that are `workspace` packages themselves do not count: the overlay rebuilds them."""
    provided = underlay_packages(environ, own_install_base)
    overridden = [name for name in selected if name in provided]
    if not overridden:
        return []
    ours = set(workspace)
    users: dict[str, list[str]] = {name: [] for name in overridden}
    for other, prefix in sorted(provided.items()):
        if other in ours:
            continue
        for dep in _dependencies(other, prefix) & users.keys():
            users[dep].append(other)
    return [Override(name, provided[name], tuple(users[name]))
            for name in overridden if users[name]]


def overrides_to_warn(selected: Iterable[str], workspace: Collection[str],
                      allowed: Iterable[str], environ: Mapping[str, str],
                      own_install_base: Path) -> list[Override]:
    """`find_overrides` without the packages `--allow-overriding` names (workspace packages
    only: a typo must not silently keep the warning)."""
    allowed = list(allowed)
    for name in allowed:
        if name not in workspace:
            import difflib  # lazy: off every run whose --allow-overriding names are known

            close = difflib.get_close_matches(name, sorted(workspace), n=1)
            raise SelectionError(f"--allow-overriding: no package named '{name}' in the workspace",
                                 hint=f"did you mean '{close[0]}'?" if close else
                                 "run 'wsbuild list -n' to see the package names")
    return [o for o in find_overrides(selected, workspace, environ, own_install_base)
            if o.package not in allowed]


def override_warning(overrides: Iterable[Override]) -> str:
    """One warning for the run: each overridden package, where, and who may see two versions."""
    overrides = list(overrides)
    lines = ["building packages that an underlay already provides to other packages, which "
             "may now see two versions at run time (keep them API and ABI compatible):"]
    for override in overrides:
        shown = ", ".join(override.users[:8]) + (
            f" and {len(override.users) - 8} more" if len(override.users) > 8 else "")
        lines.append(f"  {override.package} (in {override.prefix}), used there by {shown}")
    names = " ".join(o.package for o in overrides)
    lines.append(f"  to build them without this warning: --allow-overriding {names}")
    return "\n".join(lines)
