"""Whether a package needs building: what its last build depended on, and what changed since.

A package is rebuilt when its source files, its package.xml, the build options that reach it,
the wsbuild version, the interpreter/underlay it builds against, the build of a workspace
dependency, or a file outside the package that its build system read (its external inputs:
CMake's regeneration list, the headers the compiler read; see `BuildTypeBase.external_inputs`)
changed, or when its install is missing or damaged. File contents are hashed only when a file's
stat signature (size, modification and change time, inode: git's index compares the same)
differs from the last build, so a no-op check costs a few stats; a file reached through a
symlink is stat'ed through it (its target's signature) and the link's own signature counts too.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.files import atomic_write
from wsbuild.workspace.package_files import package_files
from wsbuild import inputs

STATE_FILE = Path(".wsbuild") / "state.json"
#: what a symlink's own entry, a dangling link and an unreadable path are recorded as
_LINK, _DANGLING, _UNREADABLE = "\0link", "\0dangling", "\0unreadable"


@dataclass(frozen=True, slots=True)
class FileRecord:
    size: int
    mtime_ns: int
    digest: str
    #: a same-size edit with its mtime set back (`cp -p`, `touch -d`) still changes these
    ctime_ns: int = 0
    inode: int = 0

    def same_stat(self, stat: os.stat_result) -> bool:
        return (self.size == stat.st_size and self.mtime_ns == stat.st_mtime_ns
                and self.ctime_ns == stat.st_ctime_ns and self.inode == stat.st_ino)


@dataclass(slots=True)
class SourceSnapshot:
    files: dict[str, FileRecord]
    digest: str
    changed: list[str] = field(default_factory=list)  # paths whose content changed


def _walk(root: Path) -> Iterable[tuple[str, os.stat_result]]:
    """Each file of the package (workspace/package_files.py) with its signature through
    symlinks; a symlink's own entry, a dangling link and an unreadable file as well."""
    for rel, entry in package_files(root):
        if entry is None:  # a directory that cannot be listed: as before, nothing of it
            continue
        try:
            # os.stat, not entry.stat(): through a symlink to its target (what the build
            # reads), and declared as the run's input
            stat = inputs.stat(entry.path)
        except FileNotFoundError:
            if entry.is_symlink():  # a dangling link: the build sees it missing
                yield rel + _DANGLING, inputs.lstat(entry.path)
            continue
        except OSError:  # a link loop, an unreadable file: never up to date
            yield rel + _UNREADABLE, inputs.lstat(entry.path)
            continue
        yield rel, stat
        if entry.is_symlink():  # where it points counts too (the target may be unchanged)
            yield rel + _LINK, inputs.lstat(entry.path)


def _hash_file(path: str) -> str:
    digest = hashlib.blake2b(digest_size=16)
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def snapshot_sources(root: Path, previous: Mapping[str, FileRecord]) -> SourceSnapshot:
    """Every file of a package with its content digest, reusing `previous` where size and
    mtime are unchanged."""
    files: dict[str, FileRecord] = {}
    changed: list[str] = []
    for rel, stat in _walk(root):
        old = previous.get(rel)
        if old is not None and old.same_stat(stat):
            files[rel] = old
            continue
        if rel.endswith((_LINK, _DANGLING, _UNREADABLE)):
            path = os.path.join(root, rel.rpartition("\0")[0])
            try:
                target = os.readlink(path)
            except OSError:
                target = ""
            digest = f"{rel.rpartition(chr(0))[2]}:{target}"
        else:
            try:
                digest = _hash_file(os.path.join(root, rel))
            except OSError:
                digest = "unreadable"
        files[rel] = FileRecord(stat.st_size, stat.st_mtime_ns, digest, stat.st_ctime_ns,
                                stat.st_ino)
        if old is None or old.digest != digest:
            changed.append(rel.split("\0")[0])
    removed = sorted(set(previous) - set(files))
    total = hashlib.blake2b(digest_size=16)
    for rel in sorted(files):
        total.update(f"{rel}\0{files[rel].digest}\n".encode())
    return SourceSnapshot(files, total.hexdigest(),
                          sorted(changed) + [r.split("\0")[0] for r in removed])


def digest_of(value: object) -> str:
    return hashlib.blake2b(json.dumps(value, sort_keys=True).encode(), digest_size=16).hexdigest()


@dataclass(slots=True)
class BuildState:
    """What the last successful build of a package depended on (build/<pkg>/.wsbuild/state.json)."""

    key: str = ""
    source: str = ""
    settings: str = ""
    dependencies: dict[str, str] = field(default_factory=dict)
    files: dict[str, FileRecord] = field(default_factory=dict)
    #: installed files relative to the install base, with their size (-1: a symlink)
    installed: list[tuple[str, int]] = field(default_factory=list)
    #: what `settings` is the digest of, so a rebuild can name the option that changed
    inputs: dict[str, object] = field(default_factory=dict)
    #: files outside the package its build system read (absolute path -> stat signature)
    external: dict[str, tuple[int, ...]] = field(default_factory=dict)
    #: the content digests of those inside the workspace's install base (a dependency's
    #: install rebuilt to the same bytes has new signatures, not new contents)
    external_digests: dict[str, str] = field(default_factory=dict)
    #: whether `external` is all the build read outside the package (the build system said
    #: so): then a dependency's rebuild matters only through those files (early cutoff)
    depinfo: bool = False

    @staticmethod
    def make_key(source: str, settings: str, dependencies: Mapping[str, str]) -> str:
        return digest_of([source, settings, sorted(dependencies.items())])


def read_state(build_dir: Path) -> BuildState | None:
    try:
        data = json.loads(inputs.read_text(build_dir / STATE_FILE))
        return BuildState(
            key=data["key"],
            source=data["source"],
            settings=data["settings"],
            dependencies=dict(data["dependencies"]),
            files={k: FileRecord(*v) for k, v in data["files"].items()},
            installed=[(p, s) for p, s in data["installed"]],
            inputs=dict(data.get("inputs") or {}),
            external={k: tuple(v) for k, v in data["external"].items()},
            external_digests=dict(data["external_digests"]),
            depinfo=bool(data["depinfo"]),
        )
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def write_state(build_dir: Path, state: BuildState) -> None:
    path = build_dir / STATE_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {
        "key": state.key,
        "source": state.source,
        "settings": state.settings,
        "dependencies": state.dependencies,
        "files": {k: [v.size, v.mtime_ns, v.digest, v.ctime_ns, v.inode]
                  for k, v in sorted(state.files.items())},
        "installed": state.installed,
        "inputs": state.inputs,
        "external": dict(sorted(state.external.items())),
        "external_digests": dict(sorted(state.external_digests.items())),
        "depinfo": state.depinfo,
    }
    atomic_write(path, json.dumps(data, separators=(",", ":")))


#: the signature of a path that does not exist (or cannot be stat'ed)
ABSENT = inputs.ABSENT
#: a file's stat signature, through symlinks (declared)
stat_signature = inputs.signature


def external_signatures(paths: Iterable[str]) -> dict[str, tuple[int, ...]]:
    return {path: stat_signature(path) for path in sorted(set(paths))}


def changed_external(external: Mapping[str, tuple[int, ...]],
                     digests: Mapping[str, str] | None = None,
                     seen: dict[str, tuple[int, ...]] | None = None) -> str | None:
    """The first recorded outside file that changed, if any: its signature, or, where
    `digests` has its content's digest, its content. `seen`: the signatures one plan has
    already taken (packages share most of their outside files: the setuptools a setup.py
    imports, CMake's modules; each is stat'ed once per plan)."""
    seen = {} if seen is None else seen
    for path, signature in external.items():
        now = seen.get(path)
        if now is None:
            now = seen[path] = stat_signature(path)
        if now != signature:
            recorded = (digests or {}).get(path)
            if recorded is None or content_digest(path) != recorded:
                return path
    return None


def content_digest(path: str) -> str:
    """A file's content digest ("" when it cannot be read)."""
    try:
        return _hash_file(path)
    except OSError:
        return ""


def cutoff_note(old: BuildState | None, dependencies: Mapping[str, str]) -> str:
    """Why a package whose dependencies were rebuilt is still up to date ("" when none was)."""
    if old is None:
        return ""
    changed = sorted(n for n in dependencies if old.dependencies.get(n) != dependencies[n])
    if not changed:
        return ""
    return (f"dependency {', '.join(changed)} rebuilt; nothing this package builds from "
            "changed → up to date")


def system_state_paths() -> list[str]:
    """What changes when a package manager changes the system or the interpreter's
    distributions: dpkg's database, and the directories pip installs distributions into."""
    import sysconfig

    paths = sysconfig.get_paths()
    return ["/var/lib/dpkg/status", *sorted({paths["purelib"], paths["platlib"]})]


def forget_state(build_dir: Path) -> None:
    """Called before a build starts: an interrupted build must not look up to date."""
    try:
        (build_dir / STATE_FILE).unlink()
    except FileNotFoundError:
        pass


def damaged_install(install_base: Path, installed: Iterable[tuple[str, int]]) -> str | None:
    """The first installed file that is missing or changed size, if any."""
    for rel, size in installed:
        path = os.path.join(install_base, rel)
        try:
            if size == -1:
                inputs.lstat(path)
            elif inputs.stat(path).st_size != size:
                return rel
        except OSError:
            return rel
    return None


@dataclass(frozen=True, slots=True)
class Reason:
    """Why a package is rebuilt: `kind` for tools, `text` for people, `details` the files,
    options or dependencies that changed."""

    #: "new", "options", "source", "dependency", "external", "install" (also "forced",
    #: "unfinished")
    kind: str
    text: str
    details: tuple[str, ...] = ()
    #: decided once the dependencies in `details` are built in this run: built only if what
    #: it read of them changed (early cutoff), else up to date
    cutoff: bool = False


def settings_changes(old: Mapping[str, object], new: Mapping[str, object]) -> list[str]:
    """`name: old → new` for each build input that differs (options by their own name)."""
    def flat(inputs: Mapping[str, object]) -> dict[str, object]:
        result: dict[str, object] = {}
        for key, value in inputs.items():
            if isinstance(value, Mapping):
                result.update({str(k): v for k, v in value.items()})
            else:
                result[key] = value
        return result

    # as state.json keeps them (tuples become lists), so only real differences show
    before, after = flat(json.loads(json.dumps(old))), flat(json.loads(json.dumps(new)))
    changes = []
    for name in sorted(set(before) | set(after)):
        if before.get(name) != after.get(name):
            changes.append(f"{name}: {_shown(before.get(name))} → {_shown(after.get(name))}")
    return changes


def _shown(value: object) -> str:
    if value is None:
        return "(none)"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(str(v) for v in value) + "]"
    return str(value)


def rebuild_reason(old: BuildState | None, snapshot: SourceSnapshot, settings: str,
                   dependencies: Mapping[str, str], install_base: Path,
                   inputs: Mapping[str, object] | None = None,
                   pending: Collection[str] = (),
                   seen: dict[str, tuple[int, ...]] | None = None) -> Reason | None:
    """None when up to date, else why not. `inputs` (what `settings` digests) lets the
    reason name the options that changed, when the last build recorded its own; `pending`:
    the dependencies this run builds or restores before this package; `seen`: the outside
    files' signatures this plan has taken (changed_external)."""
    if old is None:
        return Reason("new", "no previous build")
    if old.settings != settings:
        changed = tuple(settings_changes(old.inputs, inputs)) if old.inputs and inputs else ()
        if changed:
            return Reason("options", "build options changed: " + "; ".join(changed), changed)
        return Reason("options", "build options, interpreter, underlay or wsbuild version "
                      "changed")
    if old.source != snapshot.digest:
        shown = ", ".join(snapshot.changed[:3]) + (" …" if len(snapshot.changed) > 3 else "")
        return Reason("source", f"source changed: {shown}" if shown else "source changed",
                      tuple(snapshot.changed))
    changed_deps = sorted(n for n in set(old.dependencies) | set(dependencies)
                          if old.dependencies.get(n) != dependencies.get(n))
    # early cutoff: a rebuilt dependency matters only through what this build read of it
    # (its recorded outside files), when the build system said what it read
    cutoff = old.depinfo and set(old.dependencies) == set(dependencies)
    if changed_deps and not cutoff:
        return Reason("dependency", "dependency rebuilt: " + ", ".join(changed_deps),
                      tuple(changed_deps))
    waiting = [n for n in changed_deps if n in pending]
    if waiting:
        return Reason("dependency", f"dependency {', '.join(waiting)} is built first; this "
                      "package only if what it read of it changes", tuple(waiting), cutoff=True)
    outside = changed_external(old.external, old.external_digests, seen)
    if outside is not None and changed_deps:
        return Reason("dependency", "dependency rebuilt: " + ", ".join(changed_deps)
                      + f" (read while building: {outside})", tuple(changed_deps))
    if outside is not None:
        return Reason("external", f"file outside the package changed: {outside}", (outside,))
    damaged = damaged_install(install_base, old.installed)
    if damaged is not None:
        return Reason("install", f"install damaged: {damaged} missing or changed", (damaged,))
    return None


def why_rebuild(old: BuildState | None, snapshot: SourceSnapshot, settings: str,
                dependencies: Mapping[str, str], install_base: Path,
                inputs: Mapping[str, object] | None = None) -> str | None:
    """None when up to date, else the reason a user should read."""
    reason = rebuild_reason(old, snapshot, settings, dependencies, install_base, inputs)
    return reason.text if reason is not None else None
