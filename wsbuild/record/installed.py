"""What a package installed, as its record holds it: each file by its lstat signature and its
content's digest, each symlink by its target. A no-op checks that it is all still there: a
file whose signature changed by its content (an installed file edited in place keeping its
size is found), a symlink by its target and by that target being there (a package moved
inside `src/` under `--symlink-install` leaves links that no longer resolve)."""

from __future__ import annotations

import os
import stat as modes
from collections.abc import Collection, Iterable
from typing import TYPE_CHECKING, NamedTuple

from wsbuild import inputs
from wsbuild.record.own_files import content_digest
from wsbuild.signature import stat_signature

if TYPE_CHECKING:
    from wsbuild.record.outside import Digests

#: what a symlink's digest starts with (its target follows)
LINK = "->"


class Installed(NamedTuple):
    """One installed path, relative to the install base."""

    rel: str
    signature: tuple[int, ...]
    #: the content's digest; for a symlink LINK + its target
    digest: str


_signature = stat_signature


def installed_entries(install_base: str, paths: Iterable[str]) -> list[Installed]:
    """The record's entries of the installed `paths` (absolute), sorted; a path gone is
    left out."""
    entries: list[Installed] = []
    for path in sorted(set(paths)):
        try:
            st = os.lstat(path)
            digest = LINK + os.readlink(path) if modes.S_ISLNK(st.st_mode) \
                else content_digest(path)
        except OSError:
            continue
        entries.append(Installed(os.path.relpath(path, install_base), _signature(st), digest))
    return entries


def damaged_install(install_base: str, installed: Collection[Installed],
                    digests: Digests | None = None) -> str | None:
    """The first installed path that is missing, changed, or a symlink that no longer points
    where it did or no longer resolves; None when all are as installed. A file whose lstat
    signature is unchanged is not read. `digests`: the plan's, which keeps what it stat'ed
    for the packages that read these files."""
    entries = list(installed)
    paths = [os.path.join(install_base, rel) for rel, _, _ in entries]
    seen_now = inputs.signatures(paths, follow_symlinks=False) if digests is None \
        else digests.lstat_signatures(paths)
    for (rel, signature, digest), path, seen in zip(entries, paths, seen_now):
        if seen == inputs.ABSENT:
            return rel
        if digest.startswith(LINK):
            if not modes.S_ISLNK(seen[0]) or _target(path) != digest[len(LINK):] \
                    or not inputs.exists(path):
                return rel
            continue
        if seen == tuple(signature):
            continue
        try:
            inputs.declare_file(path)
            if modes.S_ISLNK(seen[0]) or content_digest(path) != digest:
                return rel
        except OSError:
            return rel
    return None


def _target(path: str) -> str | None:
    try:
        return os.readlink(path)
    except OSError:
        return None
