"""Shell quoting of paths and values in generated scripts, checked in real shells."""

from __future__ import annotations

import subprocess

import pytest
from test_prefix_trees import shell_or_skip

from wsbuild.errors import WsbuildError
from wsbuild.prefix.quoting import prefixed_word, sh_quote, validate_package_name, validate_variable_name

NASTY = ["plain", "with space", "it's", "$HOME", "`id`", "$(id)", '"dq"', "back\\slash", "new\nline",
         "", "'", "*", "~user", "a;b|c&d"]


@pytest.mark.parametrize("shell", ["bash", "dash", "zsh"])
def test_quoted_words_come_back_unchanged(shell: str) -> None:
    program = "".join(f"printf '%s\\0' {sh_quote(text)}\n" for text in NASTY)
    program += "".join(
        f"printf '%s\\0' {prefixed_word('P', text)}\n" for text in NASTY
    )

    completed = subprocess.run([shell_or_skip(shell), "-c", f"P='/pre fix'\n{program}"],
                               capture_output=True, check=True, env={"HOME": "/h"})

    values = completed.stdout.decode().split("\0")[:-1]
    assert values[: len(NASTY)] == NASTY
    assert values[len(NASTY):] == ["/pre fix" + (f"/{t}" if t else "") for t in NASTY]


@pytest.mark.parametrize("name", ["rclpy", "a", "my_pkg2"])
def test_valid_package_names(name: str) -> None:
    assert validate_package_name(name) == name


@pytest.mark.parametrize("name", ["$(x)", "A", "2pkg", "pkg-name", "pkg name", "", "pkg\n"])
def test_invalid_package_names(name: str) -> None:
    with pytest.raises(WsbuildError):
        validate_package_name(name)


def test_variable_names() -> None:
    assert validate_variable_name("LD_LIBRARY_PATH") == "LD_LIBRARY_PATH"
    for bad in ("A-B", "1A", "A B", "", "A=1"):
        with pytest.raises(WsbuildError):
            validate_variable_name(bad)
