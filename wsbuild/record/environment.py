"""The environment variables in a package's record: those its steps were observed to read
(observe/), whatever their name, each by a digest of its value (a value is never written
down); a variable no step read is no input, whatever its name. A step that read every
variable (a shell's `export -p`, `env` alone) holds them all; one that listed their names
holds the set of names.

Never held (`NEVER_HELD`): what wsbuild sets for one run only (its jobserver's descriptors, a
stage's `DESTDIR`, the compiler cache's and distcc's private files: the builder names them
for each step) and what observing a step sets (`LD_PRELOAD`'s observer, `WSOBSERVE_*`, the
hook's `PYTHONPATH` entry, observe/step_environment.py); wsbuild's own settings
(`WSBUILD_*`: what of them shapes a build is an option of the record); and what the user
names in the defaults file's `env-ignore:` or with `--env-ignore`.

Normalized before the digest: the entries of a path list (a variable named `…PATH`) that lie
in the workspace's own install base are dropped (sourcing `install/setup.bash` adds them; what
a build reads there is its dependencies', which the record holds by their records), and a
variable left empty by that counts as unset; `LD_LIBRARY_PATH` counts as the set of its
directories (the ROS wheels' bootstrapper adds its own in a different order in every
process). Any other value counts whole, a path into `install/` too."""

from __future__ import annotations

import fnmatch
import functools
import os
import re
from collections.abc import Callable, Collection, Iterable, Mapping

from wsbuild.hashes import blake2b
from wsbuild.record.reason import Dirty, Reason


#: variables no record holds, whoever reads them (names, or fnmatch patterns with `*`)
NEVER_HELD: tuple[str, ...] = ("WSBUILD_*", "WSOBSERVE_*")
#: path lists whose directory order no build depends on (set order in each process)
UNORDERED = frozenset({"LD_LIBRARY_PATH"})
#: the digest of a variable that is not set
UNSET = "-"


@functools.lru_cache(maxsize=16)
def _pattern(patterns: tuple[str, ...]) -> re.Pattern[str]:
    return re.compile("|".join(fnmatch.translate(p) for p in patterns) or r"(?!)")


def matches(name: str, patterns: Iterable[str]) -> bool:
    """Whether `name` is one of `patterns` (an exact name, or an fnmatch pattern with `*`)."""
    return _pattern(tuple(patterns)).match(name) is not None


@functools.lru_cache(maxsize=1024)
def _digest(value: str) -> str:
    # (cached: a plan asks of the same values for every package)
    return blake2b(value.encode("utf-8", "surrogateescape"), digest_size=8).hexdigest()


def is_path_list(name: str) -> bool:
    return name.endswith("PATH")


def normalized(name: str, value: str, own: str) -> str | None:
    """The value as the record compares it: a path list's entries in `own` (the workspace's
    install base, with a trailing separator) dropped, LD_LIBRARY_PATH as a set; None when
    nothing is left of a value that had entries there."""
    if own and is_path_list(name) and own.rstrip(os.sep) in value:
        entries = value.split(os.pathsep)
        kept = [e for e in entries if not (e + os.sep).startswith(own)]
        if len(kept) != len(entries):
            if not any(kept):
                return None
            value = os.pathsep.join(kept)
    if name in UNORDERED:
        value = os.pathsep.join(sorted(set(value.split(os.pathsep))))
    return value


def held(name: str, ignored: Collection[str] = ()) -> bool:
    """Whether a record holds the variable `name` when a step reads it."""
    return _held(name, ignored if type(ignored) is tuple else tuple(ignored))


@functools.lru_cache(maxsize=4096)
def _held(name: str, ignored: tuple[str, ...]) -> bool:
    # (cached: a plan asks of the same names for every package)
    return not matches(name, (*NEVER_HELD, *ignored))


def variable_digests(environ: Mapping[str, str | None], names: Iterable[str], *,
                     own_install: str = "", ignored: Collection[str] = ()) -> dict[str, str]:
    """name -> digest of its value in `environ` (UNSET when not set; a None value is unset),
    for each of `names` a record holds (sorted by name)."""
    own = own_install.rstrip(os.sep) + os.sep if own_install else ""
    digests: dict[str, str] = {}
    for name in sorted(set(names)):
        if not held(name, ignored):
            continue
        value = environ.get(name)
        value = normalized(name, value, own) if value is not None else None
        digests[name] = _digest(value) if value is not None else UNSET
    return digests


def names_digest(environ: Mapping[str, str | None], *, ignored: Collection[str] = ()) -> str:
    """A digest of which variables are set (the names a step listed), those never held left
    out."""
    names = sorted(n for n, v in environ.items() if v is not None and held(n, ignored))
    return _digest("\0".join(names))


def changed_names(old: Mapping[str, str], new: Mapping[str, str]) -> list[str]:
    """The variables set, unset or changed between two records' digests, sorted."""
    return sorted(name for name in set(old) | set(new) if old.get(name) != new.get(name))


def environment_digests(environ: Mapping[str, str], *,
                        leave_out: Callable[[str], bool]) -> dict[str, str]:
    """Every variable of `environ` but those `leave_out` names, by the digest of its value as
    a record compares it (LD_LIBRARY_PATH as a set), wsbuild's own settings included: what a
    command's recording keeps of the environment it ran in (engine/replay.py)."""
    return {name: _digest(normalized(name, value, "") or "")
            for name, value in sorted(environ.items()) if not leave_out(name)}


def variables_changed(changed: Collection[str], *, redo: tuple[str, ...] = ()) -> Reason:
    """The reason of a change of the variables `changed` (sorted), in the dirty check's
    words."""
    names = tuple(changed)
    shown = ", ".join(names[:5]) + (" …" if len(names) > 5 else "")
    return Reason(Dirty.ENVIRONMENT, f"environment variable changed: {shown}", names,
                  redo=redo)


def environment_reason(before: Mapping[str, str], now: Mapping[str, str]) -> Reason | None:
    """Why two environments' digests (`environment_digests`) are not the same one: the
    variables set, unset or changed; None when they are."""
    changed = changed_names(before, now)
    return variables_changed(changed) if changed else None
