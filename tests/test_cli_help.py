"""Each verb's --help fits one screen (50 lines of 100 columns); --help-all lists every option."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

import pytest

from wsbuild.cli import VERBS as VERBS_OF_CLI
from wsbuild.cli import build_parser

VERBS = [["build"], ["test"], ["list"], ["graph"], ["info"], ["clean"], ["test-result"],
         ["run"], ["pkg", "create"], ["underlay"], ["cache"], ["completion"], ["mixin"],
         ["mixin", "show"], ["deps"], ["report"]]
SCREEN = 50


def _help(args: list[str], flag: str) -> str:
    env = dict(os.environ, COLUMNS="100")
    done = subprocess.run([sys.executable, "-m", "wsbuild", *args, flag], env=env,
                          capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, done.stderr
    return done.stdout


def _options(args: list[str]) -> set[str]:
    parser = build_parser()
    for name in args:
        verbs = next(a for a in parser._actions  # noqa: SLF001
                     if isinstance(a, argparse._SubParsersAction))  # noqa: SLF001
        parser = verbs.choices[name]
    return {o for a in parser._actions for o in a.option_strings  # noqa: SLF001
            if o.startswith("--") and o not in ("--help", "--help-all")
            and a.help != argparse.SUPPRESS}  # the --no- forms: said once, in --help-all


@pytest.mark.parametrize("args", VERBS, ids=lambda a: " ".join(a))
def test_help_fits_one_screen(args: list[str]) -> None:
    text = _help(args, "--help")
    lines = text.splitlines()
    assert len(lines) <= SCREEN, f"{len(lines)} lines:\n{text}"
    assert max(len(line) for line in lines) <= 100


@pytest.mark.parametrize("args", [["build"], ["test"], ["list"], ["clean"], ["graph"], ["info"]],
                         ids=lambda a: " ".join(a))
def test_help_all_lists_every_option_and_help_names_the_rest(args: list[str]) -> None:
    short, full = _help(args, "--help"), _help(args, "--help-all")
    options = _options(args)
    assert all(option in full for option in options), sorted(o for o in options if o not in full)
    left_out = [o for o in options if f"  {o}" not in short]
    assert left_out, "nothing left out: --help-all is pointless"
    assert "--help-all" in short.splitlines()[0]  # the usage line says where the rest is
    assert "--packages-select-regex" not in short and "--packages-select-regex" in full
    assert "Every on/off option --X also has --no-X" in full


def _wsbuild(*args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, COLUMNS="100")
    return subprocess.run([sys.executable, "-m", "wsbuild", *args], env=env,
                          capture_output=True, text=True, timeout=60, check=False)


def test_bare_wsbuild_lists_the_verbs_in_a_users_order_with_what_each_does() -> None:
    done = _wsbuild()
    assert done.returncode == 2
    assert "required" not in done.stdout + done.stderr
    listed = [line.split(None, 1) for line in done.stdout.splitlines()
              if line.startswith("  ") and not line.lstrip().startswith("-")
              and len(line.split(None, 1)) == 2]
    names = [name for name, _ in listed]
    assert names[:6] == ["build", "test", "test-result", "list", "graph", "info"]
    assert sorted(names) == sorted(VERBS_OF_CLI)
    for name, summary in listed:  # one style: a capital first, no full stop
        assert summary[0].isupper() and not summary.endswith("."), (name, summary)
    assert "wsbuild VERB --help" in done.stdout
    assert _wsbuild("--help").stdout == done.stdout


@pytest.mark.parametrize(("argv", "wanted"), [
    (["biuld"], "unknown verb 'biuld': did you mean 'build'?"),
    (["tset"], "unknown verb 'tset': did you mean 'test'?"),
    (["--log-base", "x", "lsit"], "unknown verb 'lsit': did you mean 'list'?"),
    (["cache", "prun"], "unknown action 'prun': did you mean 'prune'?"),
])
def test_a_mistyped_verb_gets_a_did_you_mean(argv: list[str], wanted: str) -> None:
    done = _wsbuild(*argv)
    assert done.returncode == 2
    assert done.stderr.splitlines()[-1].endswith(wanted), done.stderr


@pytest.mark.parametrize(("argv", "wanted"), [
    (["build", "--packages-selct", "a"], "(did you mean '--packages-select'?)"),
    (["test", "--pytst-args", "-x"], "(did you mean '--pytest-args'?)"),
    (["list", "--topological-ordr"], "(did you mean '--topological-order'?)"),
])
def test_a_mistyped_option_gets_a_did_you_mean(argv: list[str], wanted: str) -> None:
    done = _wsbuild(*argv)
    assert done.returncode == 2
    assert done.stderr.splitlines()[-1].endswith(wanted), done.stderr


def test_a_word_like_no_verb_lists_them() -> None:
    done = _wsbuild("frobnicate")
    assert done.returncode == 2
    assert "unknown verb 'frobnicate'; the verbs: build, test, test-result," in done.stderr


def _sections(text: str) -> dict[str, str]:
    """The help's option groups: heading → its lines."""
    sections: dict[str, str] = {}
    heading = ""
    for line in text.splitlines():
        if line and not line.startswith(" ") and line.endswith(":"):
            heading = line[:-1]
        elif line.startswith(" "):
            sections[heading] = sections.get(heading, "") + line + "\n"
    return sections


def test_build_help_shows_install_deps_and_files_timings_apart_from_cmake() -> None:
    sections = _sections(_help(["build"], "--help"))
    assert "  --install-deps" in "".join(sections.values())
    assert "  --timings" in "".join(sections.values())
    assert "--timings" not in sections["CMake packages"]
    assert "--cmake-args" in sections["CMake packages"]


@pytest.mark.parametrize(("verb", "actions"), [
    ("cache", ["stats", "prune", "verify"]), ("pkg", ["create"]),
    ("underlay", ["check", "repair"]), ("mixin", ["add", "remove", "update", "list", "show"]),
])
def test_a_verb_with_actions_alone_lists_them(verb: str, actions: list[str]) -> None:
    done = _wsbuild(verb)
    assert done.returncode == 2 and "required" not in done.stderr
    listed = [line.split()[0] for line in done.stdout.splitlines()
              if line.startswith("  ") and not line.lstrip().startswith("-")
              and line.split()[0] in actions]
    assert listed == actions, done.stdout
