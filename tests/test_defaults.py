"""Defaults files (colcon-defaults' format, then wsbuild.yaml): strict, line-accurate, CLI wins."""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from conftest import run_wsbuild

from wsbuild.cli import build_parser
from wsbuild.verbs.defaults import (
    DefaultsError,
    apply_defaults,
    check_entries,
    chosen_verb,
    defaults_files,
    parse_with_defaults,
    read_entries,
    workspace_option,
)


def _parser(_verbs: set[str] | None = None) -> argparse.ArgumentParser:
    return build_parser(pkg_arguments=True)


def _check(path: Path, text: str) -> list:  # type: ignore[type-arg]
    path.write_text(text)
    return check_entries(read_entries(path), _parser())


def _error(path: Path, text: str) -> str:
    with pytest.raises(DefaultsError) as info:
        _check(path, text)
    return str(info.value)


# ------------------------------------------------------------------------ which files


def test_colcon_home_then_the_workspace_file(tmp_path: Path) -> None:
    home, ws = tmp_path / "home", tmp_path / "ws"
    (home / ".colcon").mkdir(parents=True)
    ws.mkdir()
    (home / ".colcon" / "defaults.yaml").write_text("{}")
    (ws / "wsbuild.yaml").write_text("{}")
    assert defaults_files({"HOME": str(home)}, ws) == [home / ".colcon" / "defaults.yaml",
                                                       ws / "wsbuild.yaml"]
    custom = tmp_path / "colcon_home"
    custom.mkdir()
    (custom / "defaults.yaml").write_text("{}")
    assert defaults_files({"HOME": str(home), "COLCON_HOME": str(custom)}, ws) == [
        custom / "defaults.yaml", ws / "wsbuild.yaml"]


def test_colcon_defaults_file_replaces_colcon_home(tmp_path: Path) -> None:
    (tmp_path / ".colcon").mkdir()
    (tmp_path / ".colcon" / "defaults.yaml").write_text("{}")
    named = tmp_path / "mine.yaml"
    named.write_text("{}")
    env = {"HOME": str(tmp_path), "COLCON_DEFAULTS_FILE": str(named)}
    assert defaults_files(env, None) == [named]


def test_a_missing_colcon_defaults_file_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(DefaultsError, match="COLCON_DEFAULTS_FILE names a file that does not"):
        defaults_files({"HOME": str(tmp_path), "COLCON_DEFAULTS_FILE": str(tmp_path / "x")},
                       None)


def test_no_files_no_defaults(tmp_path: Path) -> None:
    assert defaults_files({"HOME": str(tmp_path)}, tmp_path) == []


# ------------------------------------------------------------------------ what they hold


def test_values_of_every_kind_are_checked_against_the_parser(tmp_path: Path) -> None:
    defaults = _check(tmp_path / "d.yaml", """\
build:
  symlink-install: true
  parallel-workers: 3
  executor: sequential
  cmake-args: [-DCMAKE_BUILD_TYPE=Release, -DX=1]
  packages-skip: [a, b]
  cmake-target: 5
test:
  pytest-args: [-x]
pkg.create:
  license: MIT
  package-format: 2
""")
    by_option = {(d.verb, d.option): d for d in defaults}
    assert by_option[("build", "symlink-install")].value is True
    assert by_option[("build", "symlink-install")].line == 2
    assert by_option[("build", "parallel-workers")].value == 3
    assert list(by_option[("build", "cmake-args")].value) == ["-DCMAKE_BUILD_TYPE=Release",
                                                              "-DX=1"]
    assert by_option[("build", "packages-skip")].dest == "packages_skip"
    assert by_option[("test", "pytest-args")].line == 9
    # a number where the command line takes a string is what the user would have typed
    assert by_option[("build", "cmake-target")].value == "5"
    assert by_option[("pkg.create", "package-format")].value == 2


def test_an_empty_file_or_verb_sets_nothing(tmp_path: Path) -> None:
    assert _check(tmp_path / "d.yaml", "") == []
    assert _check(tmp_path / "d.yaml", "build:\n") == []


def test_unknown_verb_names_file_line_and_valid_verbs(tmp_path: Path) -> None:
    message = _error(tmp_path / "d.yaml", "build:\n  force: true\nbiuld:\n  force: true\n")
    assert message.startswith(f"{tmp_path / 'd.yaml'}:3: unknown verb 'biuld'")
    assert message.endswith("(did you mean 'build'?)")  # the verbs' list would bury it
    unlike = _error(tmp_path / "e.yaml", "zzzqqq:\n  force: true\n")
    assert "pkg.create" in unlike and "test-result" in unlike


def test_unknown_option_names_file_line_and_valid_options(tmp_path: Path) -> None:
    message = _error(tmp_path / "d.yaml", "build:\n  force: true\n  symlink_install: true\n")
    assert message.startswith(f"{tmp_path / 'd.yaml'}:3: 'build' has no option "
                              "'symlink_install'")
    assert message.endswith("(did you mean 'symlink-install'?)")  # no list buries it
    assert "merge-install" not in message
    unlike = _error(tmp_path / "e.yaml", "build:\n  zzzqqq: true\n")
    assert "merge-install" in unlike  # nothing close: the valid options are listed


def test_dashes_in_option_names_are_pointed_out(tmp_path: Path) -> None:
    message = _error(tmp_path / "d.yaml", "build:\n  --force: true\n")
    assert "without the leading dashes: 'force'" in message


@pytest.mark.parametrize(("text", "expected"), [
    ("build:\n  parallel-workers: four\n", "expected an integer, got 'four'"),
    ("build:\n  parallel-workers: true\n", "expected an integer, got True"),
    ("build:\n  symlink-install: 'yes'\n", "expected true or false, got 'yes'"),
    ("build:\n  cmake-args: -DX=1\n", "expected a list of strings, e.g. [a, b], got '-DX=1'"),
    ("build:\n  executor: fast\n", "'fast' is not one of the choices: parallel, sequential"),
    ("build:\n  packages-above-depth: []\n", "expected at least one value"),
    ("build:\n  cmake-target: {a: 1}\n", "expected a string"),
])
def test_wrong_value_types_name_the_line_and_what_is_expected(tmp_path: Path, text: str,
                                                               expected: str) -> None:
    message = _error(tmp_path / "d.yaml", text)
    assert message.startswith(f"{tmp_path / 'd.yaml'}:2: 'build: ")
    assert expected in message


def test_invalid_yaml_names_the_line(tmp_path: Path) -> None:
    message = _error(tmp_path / "d.yaml", "build:\n  force: true\n  cmake-args: [a\n")
    assert message.startswith(f"{tmp_path / 'd.yaml'}:4: invalid YAML")


def test_shapes_other_than_verb_to_options_are_errors(tmp_path: Path) -> None:
    assert "expected a mapping of verbs to options" in _error(tmp_path / "d.yaml", "- build\n")
    assert ":1: 'build' must map option names to values" in _error(tmp_path / "d.yaml",
                                                                  "build: true\n")
    message = _error(tmp_path / "d.yaml", "build:\n  force: true\n  force: false\n")
    assert ":3: duplicate option of 'build' 'force'" in message


def test_options_before_the_verb_are_colcons_global_ones(tmp_path: Path) -> None:
    """colcon's --log-base and --log-level come before the verb; nothing else does."""
    (default,) = _check(tmp_path / "d.yaml", "'':\n  log-base: /tmp/log\n")
    assert (default.dest, default.value) == ("global_log_base", "/tmp/log")
    message = _error(tmp_path / "e.yaml", "'':\n  symlink-install: true\n")
    assert "has no option 'symlink-install'" in message and "log-base, log-level" in message


def test_later_files_win_option_by_option(tmp_path: Path) -> None:
    first, second = tmp_path / "a.yaml", tmp_path / "b.yaml"
    first.write_text("build:\n  parallel-workers: 2\n  force: true\n")
    second.write_text("build:\n  parallel-workers: 5\n")
    defaults = check_entries([*read_entries(first), *read_entries(second)], _parser())
    assert {(d.option, d.value, d.path) for d in defaults} == {
        ("parallel-workers", 5, second), ("force", True, first)}


# ------------------------------------------------------------------------ applying them


def _parse(tmp_path: Path, yaml_text: str, *argv: str) -> argparse.Namespace:
    ws = tmp_path / "ws"
    (ws / "src").mkdir(parents=True, exist_ok=True)
    (ws / "wsbuild.yaml").write_text(yaml_text)
    return parse_with_defaults(list(argv), {"HOME": str(tmp_path)}, ws, _parser)


def test_the_command_line_wins_over_the_files(tmp_path: Path) -> None:
    text = "build:\n  parallel-workers: 2\n  cmake-args: [-DA=1]\n  symlink-install: true\n"
    args = _parse(tmp_path, text, "build")
    assert (args.parallel_workers, list(args.cmake_args), args.symlink_install) == (
        2, ["-DA=1"], True)
    args = _parse(tmp_path, text, "build", "--parallel-workers", "7", "--cmake-args=-DB=2",
                  "--cmake-args=-DC=3")
    # an option given on the command line replaces the file's list, it does not extend it
    assert (args.parallel_workers, list(args.cmake_args)) == (7, ["-DB=2", "-DC=3"])
    # an on/off option the file turned on, turned off again
    assert _parse(tmp_path, text, "build", "--no-symlink-install").symlink_install is False


def test_an_option_of_two_names_is_set_by_either_and_no_form_is_a_key(tmp_path: Path) -> None:
    """`require-linters` and `strict-linters` (one option) are both keys of `test:`; the
    `--no-` forms are not (`symlink-install: false` says it)."""
    assert _parse(tmp_path, "test:\n  require-linters: true\n", "test").strict_linters is True
    assert _parse(tmp_path, "test:\n  strict-linters: true\n", "test").strict_linters is True
    message = _error(tmp_path / "d.yaml", "build:\n  no-symlink-install: true\n")
    assert "'build' has no option 'no-symlink-install'" in message


def test_every_on_off_option_has_its_no_form() -> None:
    """Each `--X` that turns something on has `--no-X`, for every verb."""
    parser = build_parser()
    missing = []
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for verb, sub in subparsers.choices.items():
        for action in sub._actions:
            if isinstance(action, argparse._StoreTrueAction):
                missing += [f"{verb} {option}" for option in action.option_strings
                            if option.startswith("--") and not option.startswith("--no-")
                            and "--no-" + option[2:] not in sub._option_string_actions]
    assert missing == []


def test_only_the_running_verbs_defaults_apply(tmp_path: Path) -> None:
    args = _parse(tmp_path, "test:\n  parallel-workers: 2\n", "build")
    assert args.parallel_workers is None


def test_nested_verbs_get_their_defaults(tmp_path: Path) -> None:
    args = _parse(tmp_path, "pkg.create:\n  license: MIT\n", "pkg", "create", "x")
    assert args.license == "MIT"


def test_the_workspace_file_is_found_from_dash_c(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    (ws / "src").mkdir(parents=True)
    (ws / "wsbuild.yaml").write_text("build:\n  parallel-workers: 4\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    for argv in (["build", "-C", str(ws)], ["build", f"--workspace={ws}"],
                 ["build", "--work", str(ws)], [f"-C{ws}"]):
        argv = argv if argv[0] == "build" else ["build", *argv]
        args = parse_with_defaults(argv, {"HOME": str(tmp_path)}, elsewhere, _parser)
        assert args.parallel_workers == 4, argv


def test_help_lists_the_defaults_in_effect_and_where_they_come_from(tmp_path: Path) -> None:
    path = tmp_path / "d.yaml"
    defaults = _check(path, "build:\n  symlink-install: true\n  cmake-args: [-DA=1, -DB=2]\n"
                            "test:\n  pytest-args: [-x]\n")
    parser = _parser()
    apply_defaults(parser, "build", defaults)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    epilog = sub.choices["build"].epilog
    assert "defaults in effect" in epilog
    assert f"symlink-install: true       {path}:2" in epilog
    assert f"cmake-args: [-DA=1, -DB=2]  {path}:3" in epilog
    assert "pytest-args" not in epilog


def test_the_verb_and_workspace_are_read_from_the_raw_command_line() -> None:
    parser = _parser()
    assert chosen_verb(parser, ["build", "--symlink-install"]) == "build"
    assert chosen_verb(parser, ["pkg", "create", "x"]) == "pkg.create"
    assert chosen_verb(parser, ["--version"]) == ""
    assert workspace_option(["build", "-C", "w"]) == "w"
    assert workspace_option(["build", "-Cw"]) == "w"
    assert workspace_option(["build", "--workspace=w"]) == "w"
    assert workspace_option(["build", "--", "-C", "w"]) is None


# ------------------------------------------------------------------------ the real CLI


def _env(home: Path, **extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("COLCON_")}
    env.update(HOME=str(home), **extra)
    return env


def test_a_real_build_takes_its_options_from_both_files(make_workspace: Callable[..., Path],
                                                        tmp_path: Path) -> None:
    ws = make_workspace({"pa": ("ament_python", [])})
    (tmp_path / ".colcon").mkdir()
    (tmp_path / ".colcon" / "defaults.yaml").write_text(
        "build:\n  symlink-install: true\n  merge-install: false\n")
    (ws / "wsbuild.yaml").write_text("build:\n  merge-install: true\n")
    script = f"cd {shlex.quote(str(ws))} && {shlex.quote(sys.executable)} -m wsbuild build"
    result = subprocess.run(["bash", "-c", script], env=_env(tmp_path), capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    assert (ws / "install" / ".colcon_install_layout").read_text() == "merged\n"
    assert (ws / "install" / "share" / "pa" / "package.xml").is_symlink()


def test_build_help_shows_the_defaults_in_effect(make_workspace: Callable[..., Path],
                                                 tmp_path: Path) -> None:
    ws = make_workspace({"pa": ("ament_python", [])})
    named = tmp_path / "team.yaml"
    named.write_text("build:\n  cmake-args: [-DCMAKE_BUILD_TYPE=Release]\n")
    (ws / "wsbuild.yaml").write_text("test:\n  pytest-args: [-x]\nbuild:\n  parallel-workers: 2\n")
    result = run_wsbuild("build", "--help", cwd=ws / "src",
                         env=_env(tmp_path, COLCON_DEFAULTS_FILE=str(named)))
    assert result.returncode == 0, result.stderr
    tail = result.stdout[result.stdout.index("defaults in effect"):].splitlines()
    assert tail[0] == ("defaults in effect (from defaults files; the command line overrides "
                       "them, an on/off option with its --no- form, e.g. --no-symlink-install):")
    assert tail[1].split() == ["cmake-args:", "[-DCMAKE_BUILD_TYPE=Release]", f"{named}:2"]
    assert tail[2].split() == ["parallel-workers:", "2", f"{ws / 'wsbuild.yaml'}:4"]
    assert len(tail) == 3  # test's defaults are not build's


def test_a_bad_defaults_file_stops_every_verb_with_file_and_line(
        make_workspace: Callable[..., Path], tmp_path: Path) -> None:
    ws = make_workspace({"pa": ("ament_python", [])})
    (ws / "wsbuild.yaml").write_text("build:\n  symlink-install: true\nlist:\n  topological: 1\n")
    for verb in ("build", "list"):
        result = run_wsbuild(verb, cwd=ws, env=_env(tmp_path))
        assert result.returncode == 2
        assert result.stderr == (f"wsbuild: error: {ws / 'wsbuild.yaml'}:4: 'list' has "
                                 "no option 'topological' (did you mean "
                                 "'topological-order'?)\n")
    assert not (ws / "install").exists()
