"""Whether a build system configures again, asked as a record is (record/dirty.py): what the
last configure used (its source directory, its arguments, digests of the compilers'
variables) is kept in the package's build directory, and compared with what the configure
would use now; the answer is a typed `Reason`, which `--dry-run` prints beside the configure
step as it prints a package's.

The file is apart from the package record because it lives by another clock: it is written
when a configure succeeds, before the build, and removed before a configure runs (a configure
that fails is tried again, and a configure wsbuild did not see finish leaves no file)."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.files import atomic_write, private_directory
from wsbuild.record.reason import Dirty, Reason

#: what the last configure used (the CMake build types write and read it)
CONFIGURED_FILE = Path(".wsbuild") / "cmake_configure.json"


@dataclass(frozen=True, slots=True)
class Configured:
    """What a configure used, as its build directory keeps it."""

    source: str
    args: tuple[str, ...]
    #: each compiler variable by a digest of its value (None: unset)
    compilers: Mapping[str, str | None] = field(default_factory=dict)

    def encode(self) -> dict[str, object]:
        return {"source": self.source, "args": list(self.args),
                "environment": dict(self.compilers)}


def decode_configured(data: object) -> Configured | None:
    """The configure `data` (a JSON value) describes; None when it is not one."""
    if not isinstance(data, dict):
        return None
    source, args, compilers = data.get("source"), data.get("args"), data.get("environment", {})
    if not isinstance(source, str) or not isinstance(args, list) \
            or not all(isinstance(arg, str) for arg in args) or not isinstance(compilers, dict) \
            or not all(isinstance(k, str) and (v is None or isinstance(v, str))
                       for k, v in compilers.items()):
        return None
    return Configured(source, tuple(args), dict(compilers))


def read_configured(build_dir: Path) -> Configured | None:
    """What the last configure in `build_dir` used; None when no configure is known to have
    finished there (or its file is not one this version writes)."""
    try:
        data = json.loads((build_dir / CONFIGURED_FILE).read_text())
    except (OSError, ValueError):
        return None
    return decode_configured(data)


def write_configured(build_dir: Path, configured: Configured) -> None:
    """Keep what the configure that just finished in `build_dir` used (private to the user:
    it holds digests, never values)."""
    path = build_dir / CONFIGURED_FILE
    private_directory(path.parent)
    atomic_write(path, json.dumps(configured.encode(), indent=1) + "\n", mode=0o600)


def forget_configured(build_dir: Path) -> None:
    """Before a configure: a configure that fails leaves no file, so the next build tries it
    again."""
    (build_dir / CONFIGURED_FILE).unlink(missing_ok=True)


def reconfigure_reason(last: Configured | None, now: Configured, *, configured: bool,
                       asked: str = "", redo: Sequence[str] = ()) -> Reason | None:
    """Why the build system configures again before its build (None: its last configure
    holds). `configured`: the build directory holds a configured build system (CMake's
    cache); `asked`: the option that asks for a configure; `redo`: the labels of the steps
    whose last run read what changed since (the package's reason, record/dirty.py: a build
    step runs the configure again when a file it watches changed, so what the configure read
    is the build step's too)."""
    if asked:
        return Reason(Dirty.FORCED, f"asked for ({asked})", (asked,))
    read = tuple(label for label in ("configure", "build") if label in redo)
    if read:
        return Reason(Dirty.REREAD, f"its last {' and '.join(read)} read what changed", read)
    if not configured:
        return Reason(Dirty.NEW, "not configured yet")
    if last is None:
        return Reason(Dirty.UNFINISHED, "its last configure did not finish here (or another "
                                        "tool configured it)")
    if last.source != now.source:
        return Reason(Dirty.SOURCE, f"its source directory moved (was {last.source})",
                      (last.source,))
    if last.args != now.args:
        changed = tuple(_changed_args(last.args, now.args))
        return Reason(Dirty.OPTIONS, "its arguments changed: " + "; ".join(changed), changed)
    compilers = tuple(name for name in sorted({*last.compilers, *now.compilers})
                      if last.compilers.get(name) != now.compilers.get(name))
    if compilers:
        return Reason(Dirty.ENVIRONMENT, f"compilers' variables changed: {', '.join(compilers)}",
                      compilers)
    return None


def _changed_args(before: Sequence[str], after: Sequence[str]) -> list[str]:
    """The arguments added and dropped (`+ARG`, `-ARG`); the order, when only it changed."""
    added = [f"+{arg}" for arg in after if arg not in before]
    dropped = [f"-{arg}" for arg in before if arg not in after]
    return added + dropped or ["their order"]
