"""The dependency check's answers, remembered under the build base while their inputs hold.

A package's unresolved build dependencies are a function of its dependencies (names, kinds,
which of them the workspace provides) and of the environment they were looked up in (the
resolver's fingerprint: search paths and the modification times of the directories a wheel,
package or library goes into). While both are unchanged, a build reads the answer from
`build/.wsbuild/unresolved.json` instead of asking the underlay again; a wheel installed or
removed changes its site directory's time, and the next build looks again."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from pathlib import Path

from wsbuild.record.model import digest_of
from wsbuild.workspace.model import Package
from wsbuild.workspace.resolve import Resolver, unresolved_build_dependencies
from wsbuild import inputs
from wsbuild.files import atomic_write

MEMO = Path(".wsbuild") / "unresolved.json"


def unresolved(packages: Iterable[Package], workspace: Mapping[str, Package],
               resolver: Resolver, build_base: Path, *, remember: bool = True
               ) -> dict[str, tuple[str, ...]]:
    """Package -> its build dependencies nothing provides, in the order of `packages`;
    remembered answers are reused while the environment's fingerprint holds (`remember`:
    new answers are written down; a dry run writes nothing)."""
    environment = digest_of(resolver.fingerprint())
    memo = _read(build_base / MEMO, environment)
    result: dict[str, tuple[str, ...]] = {}
    changed = False
    for package in packages:
        question = _question(package, workspace)
        answer = memo.get(package.name)
        if answer is None or answer[0] != question:
            missing = unresolved_build_dependencies([package], workspace, resolver)
            answer = (question, tuple(dep.name for dep in missing.get(package.name, ())))
            memo[package.name] = answer
            changed = True
        if answer[1]:
            result[package.name] = answer[1]
    if changed and remember:
        _write(build_base / MEMO, environment, memo)
    return result


def _question(package: Package, workspace: Mapping[str, Package]) -> str:
    """What was asked of a package: its dependencies and which of them are in the workspace."""
    deps = sorted({(d.name, d.kind.value, d.name in workspace) for d in package.dependencies})
    return digest_of([package.manifest is None, deps])


def _read(path: Path, environment: str) -> dict[str, tuple[str, tuple[str, ...]]]:
    try:
        data = json.loads(inputs.read_text(path))
        if data.get("environment") != environment:
            return {}
        return {name: (str(q), tuple(str(d) for d in deps))
                for name, (q, deps) in data["packages"].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}


def _write(path: Path, environment: str,
           memo: Mapping[str, tuple[str, tuple[str, ...]]]) -> None:
    """Best effort: a build that cannot write its memo looks again next time."""
    data = {"environment": environment,
            "packages": {name: [q, list(deps)] for name, (q, deps) in sorted(memo.items())}}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, json.dumps(data, separators=(",", ":")))
    except OSError:
        pass
