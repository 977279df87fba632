"""Packages fetched from source, as `rosinstall_generator … | vcs import src` does: the ROS
distro's index (REP 153 `distribution.yaml`, read with the `rosdistro` library; the index URL
from `ROSDISTRO_INDEX_URL`, as rosdistro takes it) names the source repository and branch of
each released package; what is fetched is written to a `.repos` file (vcstool's format) and
cloned with vcstool's `vcs-import`."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from wsbuild.deps.index import error_line
from wsbuild.files import atomic_write
from wsbuild.patterns import lazy

#: the `.repos` file `deps install --from-source` writes and extends, in the workspace root
REPOS_FILE = "from-source.repos"
#: how long what an http(s) index said is kept
SOURCES_TTL = 24 * 3600.0
#: the longest one `vcs import` may take
IMPORT_TIMEOUT = 1800.0
#: a repository name of the index, used as the folder under src/
_REPOSITORY_NAME = lazy(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")
#: a branch or tag name (never an option, never a path out of the folder)
_VERSION = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._/+-]*$")
#: the URL schemes a source repository may use
_URL = lazy(r"^(https?|git|ssh|file)://[^\s]+$|^git@[^\s:]+:[^\s]+$")

Run = Callable[..., "subprocess.CompletedProcess[str]"]


@dataclass(frozen=True, slots=True)
class SourceRepository:
    """Where a released package's source lives: the index's `source:` entry of its repository."""

    name: str
    type: str
    url: str
    version: str
    #: the packages the index releases from it
    packages: tuple[str, ...] = ()

    def problem(self) -> str:
        """Why wsbuild will not clone it (empty when it will)."""
        if self.type != "git":
            return f"its source is a {self.type!r} repository; wsbuild fetches git ones"
        if not _REPOSITORY_NAME.match(self.name) or ".." in self.name:
            return f"the repository name {self.name!r} is not a folder name"
        if not _URL.match(self.url):
            return f"the source URL {self.url!r} is not a git URL"
        if not _VERSION.match(self.version) or ".." in self.version:
            return f"the source version {self.version!r} is not a branch or tag name"
        return ""

    def entry(self) -> dict[str, str]:
        """This repository's entry in a `.repos` file."""
        return {"type": self.type, "url": self.url, "version": self.version}


@dataclass(frozen=True, slots=True)
class FromSource:
    """A key no installer provides that the distro's index releases from a source repository."""

    key: str
    needed_by: tuple[str, ...]
    repository: SourceRepository


@dataclass(frozen=True, slots=True)
class DistroSources:
    """The distro's index: released package -> its source repository."""

    distro: str
    index_url: str
    repositories: Mapping[str, SourceRepository]
    #: released package name -> repository name (packages without a source entry left out)
    package_repository: Mapping[str, str]

    def repository_of(self, package: str) -> SourceRepository | None:
        name = self.package_repository.get(package)
        return self.repositories[name] if name is not None else None


def sources_from_distribution(distro: str, index_url: str, distribution: Any) -> DistroSources:
    """A rosdistro `DistributionFile` -> the source repository of every released package."""
    repositories: dict[str, SourceRepository] = {}
    owners: dict[str, str] = {}
    for name, repository in sorted(distribution.repositories.items()):
        source = repository.source_repository
        if source is None or repository.release_repository is None:
            continue
        packages = tuple(sorted(repository.release_repository.package_names))
        repositories[name] = SourceRepository(name, str(source.type), str(source.url),
                                              str(source.version or ""), packages)
        for package in packages:
            owners[package] = name
    return DistroSources(distro, index_url, repositories, owners)


def load_distro_sources(distro: str, *, cache_dir: Path | None = None, now: float = 0.0,
                        refresh: bool = False) -> tuple[DistroSources | None, str]:
    """The distro's source repositories from its index, and a line saying where they came
    from; (None, why not) without rosdistro or a readable index. With `cache_dir`, what an
    http(s) index said is kept for a day (a local index is read each time)."""
    try:
        import rosdistro  # type: ignore[import-untyped]
    except ImportError:
        return None, "rosdistro is not installed (pip install rosdistro)"
    url = str(rosdistro.get_index_url())
    remembered = _remembered_file(cache_dir, url, distro)
    if remembered is not None and not refresh:
        sources = _read_remembered(remembered, distro, url, now)
        if sources is not None:
            return sources, f"index {url} (remembered; --refresh reads it again)"
    try:
        index = rosdistro.get_index(url)
        if distro not in index.distributions:
            return None, f"the index {url} has no distribution {distro!r}"
        distribution = rosdistro.get_distribution_file(index, distro)
    except Exception as exc:  # rosdistro raises URLError, YAML, assertion and its own errors
        return None, (f"cannot read the index {url}: {_reason(exc)} (ROSDISTRO_INDEX_URL may "
                      "name a local copy)")
    sources = sources_from_distribution(distro, url, distribution)
    if remembered is not None:
        _remember(remembered, sources, now)
    return sources, f"index {url}"


def _reason(exc: BaseException) -> str:
    """The innermost reason of a (nested) URLError, without the URL rosdistro appends."""
    reason: object = exc
    while isinstance(getattr(reason, "reason", None), BaseException):
        reason = reason.reason  # type: ignore[attr-defined]
    text = str(getattr(reason, "strerror", None) or reason).splitlines()
    first = text[0] if text else type(exc).__name__
    first = first.split(" (http")[0].split(" (file:")[0]
    while first.startswith("<urlopen error "):
        first = first[len("<urlopen error "):].removesuffix(">")
    return first.rstrip(">")


def _remembered_file(cache_dir: Path | None, url: str, distro: str) -> Path | None:
    if cache_dir is None or not url.startswith(("http://", "https://")):
        return None
    digest = hashlib.sha256(f"{url}\n{distro}".encode()).hexdigest()[:16]
    return cache_dir / f"sources-{distro}-{digest}.json"


def _read_remembered(path: Path, distro: str, url: str, now: float) -> DistroSources | None:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if not 0 <= now - float(data["time"]) < SOURCES_TTL:
            return None
        repositories = {name: SourceRepository(name, *entry[:3], tuple(entry[3]))
                        for name, entry in data["repositories"].items()}
    except (OSError, ValueError, KeyError, TypeError):
        return None
    owners = {package: name for name, repository in repositories.items()
              for package in repository.packages}
    return DistroSources(distro, url, repositories, owners)


def _remember(path: Path, sources: DistroSources, now: float) -> None:
    data = {"time": now, "repositories": {
        name: [r.type, r.url, r.version, list(r.packages)]
        for name, r in sorted(sources.repositories.items())}}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, json.dumps(data, sort_keys=True) + "\n")
    except OSError:
        pass  # an unwritable cache only costs the next look a download


def write_repos_file(path: Path, repositories: Iterable[SourceRepository]) -> dict[str, Any]:
    """Add `repositories` to the `.repos` file at `path` (kept entries stay as they are),
    sorted by name; returns its `repositories` mapping."""
    entries: dict[str, Any] = {}
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
        if isinstance(data, dict) and isinstance(data.get("repositories"), dict):
            entries = dict(data["repositories"])
    except FileNotFoundError:
        pass
    for repository in repositories:
        entries.setdefault(repository.name, repository.entry())
    text = ("# the sources `wsbuild deps install --from-source` fetched (vcstool's format):\n"
            "# vcs-import src < " + path.name + "\n"
            + yaml.safe_dump({"repositories": dict(sorted(entries.items()))},
                             default_flow_style=False, sort_keys=True))
    atomic_write(path, text)
    return entries


def vcs_command(repos_file: Path, src: Path) -> list[str]:
    """`vcs-import --input FILE --skip-existing -- SRC`, the venv's own first. (`vcs import`
    itself imports pkg_resources, which setuptools 82 and later no longer have; vcstool's
    `vcs-import` program is the same command without that.)"""
    beside = Path(sys.executable).parent / "vcs-import"
    program = str(beside) if beside.is_file() else (shutil.which("vcs-import") or "vcs-import")
    return [program, "--input", str(repos_file), "--skip-existing", "--", str(src)]


def import_repositories(repos_file: Path, src: Path, environ: Mapping[str, str],
                        run: Run = subprocess.run) -> tuple[bool, str]:
    """Clone what `repos_file` lists into `src` (existing folders left alone)."""
    command = vcs_command(repos_file, src)
    env = dict(environ, GIT_TERMINAL_PROMPT="0")
    try:
        done = run(command, capture_output=True, text=True, check=False, env=env,
                   timeout=IMPORT_TIMEOUT)
    except subprocess.TimeoutExpired:
        return False, f"vcs import took longer than {IMPORT_TIMEOUT:.0f} s"
    except OSError as exc:
        return False, f"cannot run vcs: {exc.strerror or exc} (pip install vcstool)"
    if done.returncode == 0:
        return True, ""
    return False, error_line(done.stdout + done.stderr)


def repositories_for(keys: Sequence[str], sources: DistroSources) -> list[SourceRepository]:
    """The source repositories holding `keys`, once each, sorted by name."""
    found = {r.name: r for r in (sources.repository_of(k) for k in keys) if r is not None}
    return [found[name] for name in sorted(found)]


# ----------------------------------------------- the fetched packages nothing needs, left out

#: the marker that leaves a fetched package out of the build (colcon honours it too)
LEFT_OUT = "COLCON_IGNORE"
_LEFT_OUT_TEXT = ("wsbuild deps install --from-source: nothing in this workspace needs this "
                  "package (a wheel may provide it); remove this file to build it\n")


def fetched_packages(folders: Iterable[Path]) -> dict[str, Path]:
    """package name -> its directory, for every package.xml in the fetched `folders`, left
    out or not (the name read as the manifest's <name>, never run)."""
    found: dict[str, Path] = {}
    for folder in folders:
        for manifest in sorted(folder.rglob("package.xml")):
            if ".git" in manifest.relative_to(folder).parts:
                continue
            match = re.search(r"<name>\s*([^<\s]+)\s*</name>",
                              manifest.read_text(encoding="utf-8", errors="replace"))
            if match:
                found.setdefault(match.group(1), manifest.parent)
    return found


def keep_only_needed(packages: Mapping[str, Path], needed: Iterable[str]) -> tuple[list[str],
                                                                                   list[str]]:
    """Leave every fetched package out of the build that is not `needed` (its marker written),
    take back a needed one left out before (only wsbuild's own marker is removed): a plain
    `wsbuild build` then builds what the workspace needs, and a wheel is not shadowed by an
    unneeded source copy of its package. Returns (left out, taken back), sorted."""
    wanted = set(needed)
    left, taken = [], []
    for name, directory in sorted(packages.items()):
        marker = directory / LEFT_OUT
        ours = marker.is_file() and marker.read_text(errors="replace") == _LEFT_OUT_TEXT
        if name in wanted:
            if ours:
                marker.unlink()
                taken.append(name)
        else:
            if not marker.exists():
                atomic_write(marker, _LEFT_OUT_TEXT)
            if ours or marker.read_text(errors="replace") == _LEFT_OUT_TEXT:
                left.append(name)
    return left, taken
