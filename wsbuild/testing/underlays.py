"""What a package's tests run against in a chained workspace underlay: the packages of the
test closure that another colcon or wsbuild workspace installed (its prefixes on the test
environment's AMENT_PREFIX_PATH or CMAKE_PREFIX_PATH carry colcon's package index,
`share/colcon-core/packages/<name>`, holding each package's run dependencies), followed
through those run dependencies. Their installed files' stat signatures enter the cached test
result's key: an underlay rebuilt under the overlay runs its tests again. Prefixes without
colcon's index (the ROS wheels' virtualenv, /opt/ros) are the interpreter's and the
system's, which the key's `tools` part holds."""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

from wsbuild import inputs
from wsbuild.prefix.layout import PACKAGE_INDEX


class UnderlayPackages:
    """The underlay prefixes of one test run's environment, each walked at most once."""

    def __init__(self, own_install: Path) -> None:
        self.own = str(own_install).rstrip(os.sep) + os.sep
        self._trees: dict[str, str] = {}

    def signature(self, names: Iterable[str], environ: Mapping[str, str]) -> str:
        """One digest of the installed files of the packages `names` (not of this workspace)
        and their run dependencies, as the underlays of `environ` provide them ("" when none
        does)."""
        prefixes = self._prefixes(environ)
        if not prefixes:
            return ""
        todo, seen, found = sorted(set(names), reverse=True), set(), []
        while todo:
            name = todo.pop()
            if name in seen:
                continue
            seen.add(name)
            for prefix in prefixes:
                try:
                    run_dependencies = inputs.read_text(Path(prefix, PACKAGE_INDEX, name))
                except OSError:
                    continue
                found.append(f"{name}\0{prefix}\0{self._tree(prefix)}")
                todo.extend(sorted({d for d in run_dependencies.strip().split(os.pathsep)
                                    if d} - seen, reverse=True))
                break
        if not found:
            return ""
        return hashlib.blake2b("\n".join(sorted(found)).encode("utf-8", "surrogateescape"),
                               digest_size=16).hexdigest()

    def _prefixes(self, environ: Mapping[str, str]) -> list[str]:
        """The prefixes on the search paths outside this workspace's install base, in order."""
        found: list[str] = []
        for variable in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH"):
            for prefix in environ.get(variable, "").split(os.pathsep):
                if prefix and not (prefix.rstrip(os.sep) + os.sep).startswith(self.own) \
                        and prefix not in found:
                    found.append(prefix)
        return found

    def _tree(self, prefix: str) -> str:
        """The stat signatures of every file below `prefix` (an isolated underlay's prefix is
        one package's; a merged one's, every package's), taken once per run."""
        if prefix not in self._trees:
            total = hashlib.blake2b(digest_size=16)
            for path in inputs.walk_files(prefix):
                total.update(f"{path}\0{inputs.signature(path)}\n"
                             .encode("utf-8", "surrogateescape"))
            self._trees[prefix] = total.hexdigest()
        return self._trees[prefix]
