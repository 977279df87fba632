"""`wsbuild mixin` and `--mixin`: colcon-mixin's files, index format and merge rules, over a
local file:// copy of a mixin repository (tests/data/mixin_index)."""

from __future__ import annotations

import argparse
import functools
import http.server
import os
import shutil
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from conftest import run_wsbuild
from wsbuild.cli import build_parser
from wsbuild.verbs.mixin import MixinError, apply_mixins, application_order, read_mixin_file

MIXIN_INDEX = Path(__file__).resolve().parent / "data" / "mixin_index"


@pytest.fixture
def index(tmp_path: Path) -> Path:
    """A copy of the fixture repository (so a test may change it)."""
    copy = tmp_path / "repo"
    shutil.copytree(MIXIN_INDEX, copy)
    return copy / "index.yaml"


def mixin(*args: str, home: Path, cwd: Path) -> tuple[int, str, str]:
    result = run_wsbuild("mixin", *args, cwd=cwd, env={**os.environ, "COLCON_HOME": str(home)})
    return result.returncode, result.stdout, result.stderr


def test_add_update_list_show_as_colcon_mixin_keeps_them(index: Path, tmp_path: Path) -> None:
    home = tmp_path / "home"
    code, out, err = mixin("add", "default", index.as_uri(), home=home, cwd=tmp_path)
    assert code == 0, err
    assert (home / "mixin_repositories.yaml").read_text() == f"default: {index.as_uri()}\n"
    code, out, err = mixin("update", home=home, cwd=tmp_path)
    assert code == 0, err
    assert "  + build-type.mixin" in out.splitlines()
    assert sorted(p.name for p in (home / "mixin" / "default").iterdir()) == [
        "build-type.mixin", "ccache.mixin", "compile-commands.mixin", "coverage.mixin",
        "ninja.mixin"]
    code, out, _ = mixin("show", "build", "release", home=home, cwd=tmp_path)
    assert out == "build:\n- release:\n    cmake-args: ['-DCMAKE_BUILD_TYPE=Release']\n"
    code, out, _ = mixin("list", home=home, cwd=tmp_path)
    assert out.splitlines()[0] == f"default: {index.as_uri()}"

    # the repository drops a file and changes another: update follows
    index.write_text("mixin:\n  - build-type.mixin\n")
    (index.parent / "build-type.mixin").write_text(
        '{"build": {"release": {"cmake-args": ["-DCMAKE_BUILD_TYPE=MinSizeRel"]}}}\n')
    code, out, err = mixin("update", "default", home=home, cwd=tmp_path)
    assert code == 0, err
    assert "  * build-type.mixin" in out.splitlines() and "  - ninja.mixin" in out.splitlines()
    assert sorted(p.name for p in (home / "mixin" / "default").iterdir()) == ["build-type.mixin"]

    code, _, err = mixin("remove", "default", home=home, cwd=tmp_path)
    assert code == 0 and not (home / "mixin" / "default").exists()
    assert (home / "mixin_repositories.yaml").read_text() == "{}\n"


def test_an_unreachable_index_is_one_line_and_exit_1(tmp_path: Path) -> None:
    home = tmp_path / "home"
    mixin("add", "gone", (tmp_path / "missing.yaml").as_uri(), home=home, cwd=tmp_path)
    code, out, _ = mixin("update", home=home, cwd=tmp_path)
    assert code == 1
    assert "cannot fetch" in out and "missing.yaml" in out


def _listing(directory: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in sorted(directory.iterdir())}


@pytest.mark.parametrize("entry", ["build-type/", "..", "../", "sub/..", "notes.txt", "42"])
def test_a_malformed_index_entry_is_one_line_and_changes_nothing(index: Path, tmp_path: Path,
                                                                  entry: str) -> None:
    home = tmp_path / "home"
    mixin("add", "default", index.as_uri(), home=home, cwd=tmp_path)
    assert mixin("update", home=home, cwd=tmp_path)[0] == 0
    before = _listing(home / "mixin" / "default")
    index.write_text(f"mixin:\n  - build-type.mixin\n  - {entry}\n")
    (index.parent / "build-type.mixin").write_text('{"build": {"release": {}}}\n')
    code, out, err = mixin("update", home=home, cwd=tmp_path)
    assert (code, err) == (1, "")
    assert f"wsbuild: error: the index at '{index.as_uri()}' names '{entry}', which is not a " \
           "mixin file (each entry is a file name ending in .mixin, e.g. build-type.mixin)" \
        in out.splitlines()
    assert _listing(home / "mixin" / "default") == before
    assert sorted(p.name for p in home.iterdir()) == ["mixin", "mixin_repositories.yaml"]


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:  # noqa: A002 (the base's name)
        pass


@pytest.fixture
def served(index: Path) -> Iterator[str]:
    """The fixture repository served over http on 127.0.0.1: its index URL."""
    handler = functools.partial(_Quiet, directory=str(index.parent))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/index.yaml"
    finally:
        server.shutdown()
        server.server_close()


def test_an_index_over_http_fetches_its_files_from_its_own_server(index: Path, served: str,
                                                                  tmp_path: Path) -> None:
    index.write_text("mixin:\n  - build-type.mixin\n  - /ccache.mixin\n"
                     "  - ./ninja.mixin\n")
    home = tmp_path / "home"
    mixin("add", "web", served, home=home, cwd=tmp_path)
    code, out, err = mixin("update", home=home, cwd=tmp_path)
    assert code == 0, out + err
    assert _listing(home / "mixin" / "web") == {
        name: (index.parent / name).read_text()
        for name in ("build-type.mixin", "ccache.mixin", "ninja.mixin")}
    code, out, _ = mixin("show", "build", "release", home=home, cwd=tmp_path)
    assert out == "build:\n- release:\n    cmake-args: ['-DCMAKE_BUILD_TYPE=Release']\n"


@pytest.mark.parametrize("form", ["path", "file-url", "other-server"])
def test_an_index_over_http_may_name_only_files_of_its_own_origin(index: Path, served: str,
                                                                  tmp_path: Path,
                                                                  form: str) -> None:
    local = tmp_path / "private" / "secret.mixin"
    local.parent.mkdir()
    local.write_text('{"build": {"secret": {"cmake-args": ["-DTOKEN=do-not-copy"]}}}\n')
    port = int(served.split(":")[2].split("/")[0])
    entry = {"path": str(local), "file-url": local.as_uri(),
             "other-server": f"http://127.0.0.1:{port + 1}/secret.mixin"}[form]
    if form == "path":
        # a path is a reference on the index's own server, never a local file
        index.write_text(f"mixin:\n  - {entry}\n")
        home = tmp_path / "home"
        mixin("add", "web", served, home=home, cwd=tmp_path)
        code, out, _ = mixin("update", home=home, cwd=tmp_path)
        assert code == 1
        assert f"cannot fetch 'http://127.0.0.1:{port}{local}'" in out, out
        assert not (home / "mixin" / "web" / "secret.mixin").exists()
        return
    index.write_text(f"mixin:\n  - build-type.mixin\n  - {entry}\n")
    home = tmp_path / "home"
    mixin("add", "web", served, home=home, cwd=tmp_path)
    code, out, err = mixin("update", home=home, cwd=tmp_path)
    assert (code, err) == (1, "")
    assert out.splitlines()[1:] == [
        f"wsbuild: error: the index at '{served}' names '{entry}', which is not on its own "
        f"server (http://127.0.0.1:{port}) (an index served over http(s) may name only files "
        "of its own origin)"]
    assert not (home / "mixin" / "web").exists()


def test_an_invalid_mixin_file_is_refused_and_the_last_good_copy_kept(index: Path,
                                                                      tmp_path: Path) -> None:
    home = tmp_path / "home"
    mixin("add", "default", index.as_uri(), home=home, cwd=tmp_path)
    assert mixin("update", home=home, cwd=tmp_path)[0] == 0
    good = (home / "mixin" / "default" / "ccache.mixin").read_text()
    (index.parent / "ccache.mixin").write_text('{"build": {"ccache": [\n')
    (index.parent / "build-type.mixin").write_text(
        '{"build": {"release": {"cmake-args": ["-DCMAKE_BUILD_TYPE=MinSizeRel"]}}}\n')
    (index.parent / "new.mixin").write_text("build: [not, a, mapping]\n")
    index.write_text(index.read_text() + "  - new.mixin\n")
    code, out, err = mixin("update", home=home, cwd=tmp_path)
    assert (code, err) == (1, "")
    lines = out.splitlines()
    assert ["  * build-type.mixin", "  ! ccache.mixin", "  ! new.mixin"] == \
        [line for line in lines if line.startswith("  ") and line[2] in "*!"]
    refusals = [line for line in lines if line.startswith("wsbuild: error:")]
    assert refusals[0].startswith(
        f"wsbuild: error: refused ccache.mixin from '{index.parent.as_uri()}/ccache.mixin': "
        "line 2: invalid YAML")
    assert refusals[0].endswith("(kept the last good copy)")
    assert refusals[1] == (
        f"wsbuild: error: refused new.mixin from '{index.parent.as_uri()}/new.mixin': line 1: "
        "expected a mapping of mixin names to options (not installed)")
    assert (home / "mixin" / "default" / "ccache.mixin").read_text() == good
    assert not (home / "mixin" / "default" / "new.mixin").exists()
    # every mixin still applies: the one updated and the one kept
    code, out, err = mixin("show", "build", home=home, cwd=tmp_path)
    assert code == 0, err
    assert "    cmake-args: ['-DCMAKE_BUILD_TYPE=MinSizeRel']" in out.splitlines()
    assert "- ccache:" in out.splitlines()


def test_an_unknown_mixin_is_a_usage_error_naming_the_known(tmp_path: Path) -> None:
    home = tmp_path / "home"
    shutil.copytree(MIXIN_INDEX, home / "mixin" / "default")
    result = run_wsbuild("build", "--mixin", "relase", cwd=tmp_path,
                         env={**os.environ, "COLCON_HOME": str(home)})
    assert result.returncode == 2
    assert "no mixin 'relase' for 'build'" in result.stderr
    assert "rel-with-deb-info, release" in result.stderr


def _args(argv: list[str], home: Path, files: dict[str, str]) -> argparse.Namespace:
    for name, text in files.items():
        (home / "mixin" / "local").mkdir(parents=True, exist_ok=True)
        (home / "mixin" / "local" / name).write_text(text)
    parser = build_parser(pkg_arguments=False)
    args = parser.parse_args(argv)
    verbs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    apply_mixins(verbs.choices[argv[0]], argv[0], args, {"COLCON_HOME": str(home)})
    return args


def test_mixins_referring_to_mixins_apply_first_and_the_referrer_wins(tmp_path: Path) -> None:
    files = {"a.mixin": '{"build": {"base": {"parallel-workers": 2, "cmake-args": ["-DA=1"]},'
                        ' "top": {"mixin": ["base"], "parallel-workers": 4,'
                        ' "cmake-args": ["-DB=1"]}}}'}
    args = _args(["build", "--mixin", "top"], tmp_path, files)
    assert (args.parallel_workers, args.cmake_args) == (4, ["-DA=1", "-DB=1"])
    mixins = {m.name: m for m in read_mixin_file(tmp_path / "mixin" / "local" / "a.mixin")}
    assert application_order(mixins, "top") == ["base", "top"]


def test_a_mixin_option_of_the_wrong_type_names_the_file_and_line(tmp_path: Path) -> None:
    files = {"bad.mixin": 'build:\n  bad:\n    symlink-install: "yes"\n'}
    with pytest.raises(MixinError) as info:
        _args(["build", "--mixin", "bad"], tmp_path, files)
    assert str(info.value).startswith(f"{tmp_path}/mixin/local/bad.mixin:3: ")
    assert "true or false" in str(info.value)


def test_a_mixin_option_wsbuild_lacks_names_the_file_and_line(tmp_path: Path) -> None:
    files = {"odd.mixin": 'build:\n  odd:\n    no-such-option: 1\n'}
    with pytest.raises(MixinError) as info:
        _args(["build", "--mixin", "odd"], tmp_path, files)
    assert "odd.mixin:3:" in str(info.value) and "--no-such-option" in str(info.value)


def test_a_circle_of_mixins_is_an_error(tmp_path: Path) -> None:
    files = {"c.mixin": '{"build": {"x": {"mixin": ["y"]}, "y": {"mixin": ["x"]}}}'}
    with pytest.raises(MixinError, match="circle: x -> y -> x"):
        _args(["build", "--mixin", "x"], tmp_path, files)
