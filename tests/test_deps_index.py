"""wsbuild/deps/index.py: the package index's answers are remembered (a day when there, an hour
when not, never a timeout), per interpreter and index settings, and `--refresh` asks again."""

from __future__ import annotations

from pathlib import Path

from wsbuild.deps.index import AnswerMemory, IndexAnswer, query


def memory(tmp_path: Path, now: float, scope: str = "s") -> AnswerMemory:
    return AnswerMemory(tmp_path / "cache" / "index-answers.json", scope, now)


def test_answers_are_remembered_a_day_when_there_and_an_hour_when_not(tmp_path: Path) -> None:
    memory(tmp_path, 1000.0).remember([
        IndexAnswer("psutil", True),
        IndexAnswer("ros-jazzy-nope", False, "ERROR: No matching distribution found"),
        IndexAnswer("slow", False, "the package index did not answer in 120 s", definite=False),
    ])
    names = ["psutil", "ros-jazzy-nope", "slow"]
    soon = memory(tmp_path, 1000.0 + 3599).recall(names)
    assert sorted(soon) == ["psutil", "ros-jazzy-nope"]  # a timeout is never remembered
    assert soon["psutil"] == IndexAnswer("psutil", True)
    assert soon["ros-jazzy-nope"].detail == ("ERROR: No matching distribution found "
                                             "(remembered; --refresh asks the index again)")
    assert sorted(memory(tmp_path, 1000.0 + 3601).recall(names)) == ["psutil"]
    assert memory(tmp_path, 1000.0 + 24 * 3600 + 1).recall(names) == {}
    # another interpreter or other index settings: nothing remembered
    assert memory(tmp_path, 1000.0, scope="other").recall(names) == {}


def test_a_broken_memory_file_is_no_error(tmp_path: Path) -> None:
    broken = memory(tmp_path, 5.0)
    broken.path.parent.mkdir(parents=True)
    broken.path.write_text("{not json")
    assert broken.recall(["psutil"]) == {}
    broken.remember([IndexAnswer("psutil", True)])
    assert broken.recall(["psutil"]) == {"psutil": IndexAnswer("psutil", True)}


def test_remembered_names_are_not_asked_and_refresh_asks_again(tmp_path: Path) -> None:
    # the interpreter does not exist: any name actually asked comes back "cannot run pip"
    python = tmp_path / "no-python"
    remembered = memory(tmp_path, 1.0)
    remembered.remember([IndexAnswer("psutil", True)])
    assert query(python, ["psutil"], {}, memory=memory(tmp_path, 2.0)) == {
        "psutil": IndexAnswer("psutil", True)}
    (asked,) = query(python, ["psutil"], {}, memory=memory(tmp_path, 2.0),
                     refresh=True).values()
    assert not asked.exists and asked.detail.startswith("cannot run pip")
    # and that failure did not replace what the index had said
    assert memory(tmp_path, 3.0).recall(["psutil"])["psutil"].exists


def test_the_answers_are_kept_in_wsbuilds_one_cache_directory(tmp_path: Path) -> None:
    """One rule for wsbuild's cache directory: WSBUILD_CACHE_DIR, else $XDG_CACHE_HOME/wsbuild
    (the build cache's rule, cache/settings.py)."""
    from wsbuild.cache.settings import default_cache_dir

    python = Path("/usr/bin/python3")
    for environ in ({"WSBUILD_CACHE_DIR": str(tmp_path / "mine"),
                     "XDG_CACHE_HOME": str(tmp_path / "xdg")},
                    {"XDG_CACHE_HOME": str(tmp_path / "xdg")}):
        kept = AnswerMemory.for_index(python, environ).path
        assert kept.is_relative_to(default_cache_dir(environ)), (environ, kept)
    assert AnswerMemory.for_index(python, {"WSBUILD_CACHE_DIR": str(tmp_path / "mine")}
                                  ).path.is_relative_to(tmp_path / "mine")
