"""`wsbuild test` before it tests: the packages whose own files changed since their last build
(the one dirty check asked of their files alone, with their records' own settings,
environment and dependencies)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from wsbuild.record.dirty import Dirty, Environment, PackageNow, dirty_reason
from wsbuild.record.model import PackageRecord, read_record
from wsbuild.record.outside import Digests
from wsbuild.record.own_files import own_files
from wsbuild.workspace.selection import Selection


class _AsRecorded(Environment):
    """The environment exactly as a record holds it (`sources_changed` asks of files only)."""

    def __init__(self, record: PackageRecord) -> None:
        object.__setattr__(self, "environ", {})
        object.__setattr__(self, "own_install", "")
        object.__setattr__(self, "ignored", ())
        object.__setattr__(self, "_record", record)

    def digests(self, names: Iterable[str]) -> dict[str, str]:
        return {name: self._record.environment[name] for name in names
                if name in self._record.environment}

    def names(self) -> str:
        return self._record.environment_names


def sources_changed(selection: Selection, names: Sequence[str]) -> dict[str, str]:
    """`wsbuild test`: the packages whose own files changed since their last build, with the
    one dirty check's words ("source changed: test/test_greeter.cpp"); each is asked with its
    record's own settings, environment and dependencies, so only its files can differ."""
    ws = selection.workspace
    outputs = tuple(str(base) for base in (ws.build_base, ws.install_base, ws.log_base))
    changed: dict[str, str] = {}
    digests = Digests()
    for name in names:
        old = read_record(ws.build_base / name)
        if old is None:
            continue
        own = own_files(selection.packages[name].path, old.own, outputs)
        now = PackageNow(own, old.settings, _AsRecorded(old), old.dependencies)
        reason = dirty_reason(old, now, install_base=ws.install_base, digests=digests)
        if reason is not None and reason.kind is Dirty.SOURCE:
            changed[name] = reason.text
    return changed
