"""wsbuild/deps/from_source.py without the network: which source entries are cloned, the
`.repos` file kept and extended, an http(s) index remembered for a day (the real fetch from
local git repositories and a local index is in tests/test_deps_sources.py)."""

from __future__ import annotations

import sys
from pathlib import Path
from urllib.error import URLError

import pytest
import yaml

from wsbuild.deps import from_source
from wsbuild.deps.from_source import (
    DistroSources,
    SourceRepository,
    repositories_for,
    vcs_command,
    write_repos_file,
)


def repository(name: str = "launch", url: str = "https://github.com/ros2/launch.git",
               version: str = "jazzy", type_: str = "git") -> SourceRepository:
    return SourceRepository(name, type_, url, version, ("launch", "launch_xml"))


def test_git_entries_with_a_branch_are_cloned() -> None:
    assert repository().problem() == ""
    assert repository(url="git@github.com:ros2/launch.git").problem() == ""
    assert repository(url="file:///srv/git/launch").problem() == ""


@pytest.mark.parametrize(("entry", "problem"), [
    (repository(type_="hg"), "its source is a 'hg' repository; wsbuild fetches git ones"),
    (repository(url="--upload-pack=touch /tmp/x"), "is not a git URL"),
    (repository(url="/srv/git/launch"), "is not a git URL"),
    (repository(version="-b"), "is not a branch or tag name"),
    (repository(version="../../x"), "is not a branch or tag name"),
    (repository(name="../escape"), "is not a folder name"),
    (repository(name="-rf"), "is not a folder name"),
])
def test_other_entries_are_refused(entry: SourceRepository, problem: str) -> None:
    assert problem in entry.problem()


def test_the_repos_file_keeps_what_it_had_and_adds_sorted(tmp_path: Path) -> None:
    path = tmp_path / "from-source.repos"
    path.write_text("repositories:\n  zeta:\n    type: git\n    url: https://x/zeta.git\n"
                    "    version: main\n")
    write_repos_file(path, [repository(), repository("ros2cli", "https://x/ros2cli.git")])
    write_repos_file(path, [repository(url="https://elsewhere/launch.git")])  # kept as was
    data = yaml.safe_load(path.read_text())
    assert list(data["repositories"]) == ["launch", "ros2cli", "zeta"]
    assert data["repositories"]["launch"] == {
        "type": "git", "url": "https://github.com/ros2/launch.git", "version": "jazzy"}
    assert path.read_text().startswith("# the sources `wsbuild deps install --from-source`")


def test_keys_map_to_their_repository_once() -> None:
    launch = repository()
    sources = DistroSources("jazzy", "file:///i.yaml", {"launch": launch},
                            {"launch": "launch", "launch_xml": "launch"})
    assert repositories_for(["launch_xml", "launch", "nowhere"], sources) == [launch]


def test_vcs_gets_its_path_after_a_double_dash(tmp_path: Path) -> None:
    command = vcs_command(tmp_path / "a.repos", tmp_path / "src")
    assert command[0].endswith("vcs-import")
    assert command[-2:] == ["--", str(tmp_path / "src")]


def test_an_unreadable_index_says_why_in_one_short_line() -> None:
    nested = URLError("<urlopen error <urlopen error [Errno -2] Name or service not known> "
                      "(https://raw.githubusercontent.com/ros/rosdistro/master/index-v4.yaml)>")
    assert from_source._reason(nested) == "[Errno -2] Name or service not known"


class FakeIndex:
    distributions = {"jazzy": {}}


class FakeRosdistro:
    """rosdistro's three calls; counts the index reads."""

    reads = 0

    @staticmethod
    def get_index_url() -> str:
        return "https://index.example/index-v4.yaml"

    @classmethod
    def get_index(cls, url: str) -> FakeIndex:
        cls.reads += 1
        return FakeIndex()

    @staticmethod
    def get_distribution_file(index: FakeIndex, distro: str) -> object:
        class Release:
            package_names = ["launch", "launch_xml"]

        class Source:
            type, url, version = "git", "https://github.com/ros2/launch.git", "jazzy"

        class Repo:
            release_repository, source_repository = Release(), Source()

        class Distribution:
            repositories = {"launch": Repo()}

        return Distribution()


def test_an_http_index_is_remembered_for_a_day(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "rosdistro", FakeRosdistro)
    FakeRosdistro.reads = 0
    first, status = from_source.load_distro_sources("jazzy", cache_dir=tmp_path, now=100.0)
    assert status == "index https://index.example/index-v4.yaml" and FakeRosdistro.reads == 1
    again, status = from_source.load_distro_sources("jazzy", cache_dir=tmp_path, now=200.0)
    assert FakeRosdistro.reads == 1 and status.endswith("(remembered; --refresh reads it again)")
    assert again is not None and first is not None
    assert again.repository_of("launch_xml") == first.repository_of("launch_xml")
    from_source.load_distro_sources("jazzy", cache_dir=tmp_path, now=200.0, refresh=True)
    from_source.load_distro_sources("jazzy", cache_dir=tmp_path, now=200.0 + 24 * 3600 + 1)
    assert FakeRosdistro.reads == 3
