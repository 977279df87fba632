"""Which workspace packages a package's steps read the install of: what its record says they
read below the install base, by the package each path belongs to. An isolated install says it
by the directory (`install/<pkg>/…`); a merged one by each package's own directories
(`share/<pkg>/`, the ament index's marker, `lib/<pkg>/`)."""

from __future__ import annotations

import os
from collections.abc import Collection
from pathlib import Path

from wsbuild.record.model import PackageRecord


def installs_read(record: PackageRecord, install_base: Path, packages: Collection[str], *,
                  merged: bool, but: str = "") -> dict[str, str]:
    """package -> the first path of its install the record's steps read, by content or by
    its entries (looking for a path that is not there is no read of it; package `but`, the
    record's own, left out; the caller leaves out what it declares)."""
    base = str(install_base).rstrip(os.sep) + os.sep
    found: dict[str, str] = {}
    for path in sorted({*record.outside.files, *record.outside.listings}):
        if not path.startswith(base):
            continue
        parts = path[len(base):].split(os.sep)
        owner = _owner(parts, packages, merged)
        if owner is not None and owner != but and owner not in found:
            found[owner] = os.path.join("install", *parts)
    return found


def _owner(parts: list[str], packages: Collection[str], merged: bool) -> str | None:
    if not merged:
        return parts[0] if parts and parts[0] in packages else None
    for index, part in enumerate(parts[:-1]):
        name = parts[index + 1]
        if part in ("share", "lib", "include") and name in packages:
            return name
    if len(parts) >= 2 and parts[-2] == "packages" and parts[-1] in packages:
        return parts[-1]
    return None


def undeclared_lines(package: str, read: dict[str, str], declared: Collection[str]) -> list[str]:
    """What to tell the user of each package whose install `package`'s steps read (`read`:
    package -> the first path read) that it does not declare."""
    return [f"{package} read {path} but does not declare {other}: add "
            f"`<depend>{other}</depend>` to its package.xml"
            for other, path in sorted(read.items()) if other not in declared]
