"""Read package.xml files once: each package read is remembered under the build base, keyed by
the manifest's bytes, the environment variables its conditions may name and the files beside
it that decide a missing build type. `list`, `graph` and a no-op build of a large workspace
then parse only what changed."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.workspace.model import Dependency, DepKind, Package, Person, VersionConstraint
from wsbuild import inputs
from wsbuild.hashes import blake2b
from wsbuild.files import atomic_write, private_directory
from wsbuild.patterns import lazy

#: bump when the remembered form of a package changes
FORMAT = 2
#: `$NAME` in a condition (REP 149)
_VARIABLE = lazy(rb"\$([A-Za-z_][A-Za-z0-9_]*)")


@dataclass(slots=True)
class ManifestMemo:
    """What earlier runs read, and what this run read; `save()` keeps the packages seen now."""

    path: Path | None
    _known: dict[str, dict[str, object]] = field(default_factory=dict)
    _seen: dict[str, dict[str, object]] = field(default_factory=dict)

    @classmethod
    def load(cls, path: Path | None) -> ManifestMemo:
        if path is None:
            return cls(None)
        try:
            data = json.loads(inputs.read_text(path))
            known = data["packages"] if data.get("format") == FORMAT else {}
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            known = {}
        return cls(path, known if isinstance(known, dict) else {})

    def key(self, manifest: Path, environ: Mapping[str, str]) -> str | None:
        """What a read of `manifest` depends on; None when it cannot be read (parse it)."""
        try:
            text = inputs.read_bytes(manifest)
        except OSError:
            return None
        digest = blake2b(text, digest_size=16)
        for name in sorted(set(_VARIABLE.findall(text))):
            value = environ.get(name.decode())
            digest.update(b"\0" + name + b"=" + (value.encode() if value is not None else b"\1"))
        for beside in ("CMakeLists.txt", "setup.py"):
            digest.update(b"1" if inputs.is_file(manifest.parent / beside) else b"0")
        return digest.hexdigest()

    def get(self, manifest: Path, key: str) -> tuple[Package, list[str]] | None:
        entry = self._known.get(str(manifest))
        if entry is None or entry.get("key") != key:
            return None
        try:
            package = package_from_json(entry["package"])  # type: ignore[arg-type]
            warnings = [str(w) for w in entry["warnings"]]  # type: ignore[union-attr]
        except (KeyError, TypeError, ValueError):
            return None
        self._seen[str(manifest)] = entry
        return package, warnings

    def put(self, manifest: Path, key: str, package: Package, warnings: list[str]) -> None:
        self._seen[str(manifest)] = {"key": key, "package": package_to_json(package),
                                     "warnings": warnings}

    def save(self) -> None:
        """Best effort, and only when something changed (a no-op writes nothing)."""
        if self.path is None or self._seen == self._known:
            return

        try:
            private_directory(self.path.parent)
            atomic_write(self.path, json.dumps({"format": FORMAT, "packages": self._seen},
                                               separators=(",", ":"), sort_keys=True))
        except OSError:
            pass


def package_to_json(package: Package) -> dict[str, object]:
    return {
        "name": package.name,
        "path": str(package.path),
        "build_type": package.build_type,
        "version": package.version,
        "manifest": str(package.manifest) if package.manifest is not None else None,
        "description": package.description,
        "licenses": list(package.licenses),
        "maintainers": [[p.name, p.email] for p in package.maintainers],
        "dependencies": [[d.name, d.kind.value, [[c.op, c.version] for c in d.constraints],
                          d.line] for d in package.dependencies],
        "member_of_groups": list(package.member_of_groups),
        "exports": [list(e) for e in package.exports],
        "refused": [list(r) for r in package.refused],
    }


def package_from_json(data: Mapping[str, object]) -> Package:
    manifest = data["manifest"]
    return Package(
        name=str(data["name"]),
        path=Path(str(data["path"])),
        build_type=str(data["build_type"]),
        version=str(data["version"]),
        manifest=Path(str(manifest)) if manifest is not None else None,
        description=str(data["description"]),
        licenses=tuple(str(x) for x in data["licenses"]),  # type: ignore[union-attr]
        maintainers=tuple(Person(str(n), e) for n, e in data["maintainers"]),  # type: ignore
        dependencies=tuple(
            Dependency(str(name), DepKind(kind), tuple(VersionConstraint(op, v)
                                                       for op, v in constraints), line)
            for name, kind, constraints, line in data["dependencies"]),  # type: ignore
        member_of_groups=tuple(str(x) for x in data["member_of_groups"]),  # type: ignore
        exports=tuple((str(t), str(x)) for t, x in data["exports"]),  # type: ignore
        refused=tuple((int(n), str(p), str(f)) for n, p, f in data["refused"]),  # type: ignore
    )
