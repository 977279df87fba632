"""The environment a package's build sees: its dependencies' package.dsv applied in-process."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from threading import Lock

from wsbuild.errors import WsbuildError
from wsbuild.prefix.dsv import Action, PackageEnvironment, resolve_package
from wsbuild.prefix.render import load_template

# build environments are computed per package build: cache each dependency's resolved
# operations, valid while none of the .dsv files they came from changes
_cache: dict[tuple[str, str], tuple[tuple[tuple[str, int], ...], PackageEnvironment]] = {}
_cache_lock = Lock()
# variables a shell sets by itself; not part of what a sourced script changed
_SHELL_OWN = frozenset({"PWD", "OLDPWD", "SHLVL", "_"})


def environment_for(prefixes: Sequence[tuple[Path, str]], base: Mapping[str, str]) -> dict[str, str]:
    """The environment after sourcing each `(prefix, package)`'s package.sh, in order.

    Each package's `share/<pkg>/package.dsv` is interpreted in-process with the semantics of
    colcon's package.sh: a prepended value moves to the front and empty entries are dropped,
    an appended value keeps its place if present. Only a script without a `.dsv`
    description (rare: a custom ament environment hook) is sourced by `/bin/sh`.
    """
    env = _Environment(base)
    for prefix, package in prefixes:
        prefix_text = str(prefix)
        for operation in _package_environment(prefix, package).operations:
            value = operation.resolve(prefix_text)
            if operation.action is Action.PREPEND:
                env.prepend(operation.name, value)
            elif operation.action is Action.APPEND:
                env.append(operation.name, value)
            elif operation.action is Action.SET:
                env.set(operation.name, value)
            elif operation.action is Action.SET_IF_UNSET:
                if not env.get(operation.name):
                    env.set(operation.name, value)
            else:
                script = operation.script_for(None)
                if script is not None:
                    path = os.path.join(prefix_text, script) if operation.relative else script
                    env.replace(_source_in_shell(Path(path), prefix_text, env.result()))
    return env.result()


def _package_environment(prefix: Path, package: str) -> PackageEnvironment:
    key = (str(prefix), package)
    with _cache_lock:
        cached = _cache.get(key)
    if cached is not None:
        stamps, resolved = cached
        if stamps == _stamps(path for path, _ in stamps):
            return resolved
    resolved = resolve_package(prefix, package)
    stamps = _stamps(str(p) for p in resolved.files)
    with _cache_lock:
        _cache[key] = (stamps, resolved)
    return resolved


def _stamps(paths: Iterable[str]) -> tuple[tuple[str, int], ...]:
    stamps = []
    for path in paths:
        try:
            stamps.append((path, os.stat(path).st_mtime_ns))
        except OSError:
            stamps.append((path, -1))
    return tuple(stamps)


class _Environment:
    """A copy of `base` whose colon-separated variables are edited as lists."""

    def __init__(self, base: Mapping[str, str]) -> None:
        self._values = dict(base)
        self._lists: dict[str, list[str]] = {}

    def get(self, name: str) -> str:
        if name in self._lists:
            return os.pathsep.join(self._lists[name])
        return self._values.get(name, "")

    def _list(self, name: str) -> list[str]:
        items = self._lists.get(name)
        if items is None:
            current = self._values.get(name, "")
            # colcon's _colcon_prepend_unique_value drops empty entries
            items = [item for item in current.split(os.pathsep) if item]
            self._lists[name] = items
        return items

    def prepend(self, name: str, value: str) -> None:
        items = self._list(name)
        items[:] = [value, *(item for item in items if item != value)]

    def append(self, name: str, value: str) -> None:
        items = self._list(name)
        if value not in items:
            items.append(value)

    def set(self, name: str, value: str) -> None:
        self._lists.pop(name, None)
        self._values[name] = value

    def replace(self, values: dict[str, str]) -> None:
        self._values = values
        self._lists.clear()

    def result(self) -> dict[str, str]:
        for name, items in self._lists.items():
            self._values[name] = os.pathsep.join(items)
        self._lists.clear()
        return dict(self._values)


def _source_in_shell(script: Path, prefix: str, env: dict[str, str]) -> dict[str, str]:
    """Source one script in /bin/sh the way colcon's package.sh would; return the new env."""
    if not script.is_file():
        # colcon prints "not found" and continues
        return env
    program = (
        load_template("prepend_unique_value.sh")
        + 'COLCON_CURRENT_PREFIX="$1"\n. "$2" 1>&2\nunset COLCON_CURRENT_PREFIX\nexec env -0\n'
    )
    import subprocess

    try:
        completed = subprocess.run(
            ["/bin/sh", "-c", program, "sh", prefix, str(script)],
            env=env, capture_output=True, check=True,
        )
    except (OSError, subprocess.CalledProcessError) as exc:
        stderr = getattr(exc, "stderr", b"") or b""
        raise WsbuildError(
            f"sourcing the environment hook failed: {stderr.decode(errors='replace').strip()}",
            path=script,
        ) from exc
    result: dict[str, str] = {}
    for entry in completed.stdout.split(b"\0"):
        name, sep, value = entry.decode(errors="surrogateescape").partition("=")
        if sep and name:
            result[name] = value
    for name in _SHELL_OWN:
        if name in env:
            result[name] = env[name]
        else:
            result.pop(name, None)
    if "COLCON_CURRENT_PREFIX" in env:
        result["COLCON_CURRENT_PREFIX"] = env["COLCON_CURRENT_PREFIX"]
    return result
