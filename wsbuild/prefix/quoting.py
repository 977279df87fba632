"""Shell quoting and the name checks that keep generated scripts free of injected code."""

from __future__ import annotations

from pathlib import Path

from wsbuild.errors import WsbuildError
from wsbuild.patterns import lazy

#: what wsbuild accepts as a package name in a generated script (REP 144, lower case)
PACKAGE_NAME = lazy(r"^[a-z][a-z0-9_]*$")
#: a POSIX environment variable name
VARIABLE_NAME = lazy(r"^[A-Za-z_][A-Za-z0-9_]*$")
#: characters that need no quoting inside double quotes next to a `$VAR`
_PLAIN = lazy(r"^[A-Za-z0-9_./+,:@%=-]*$")


def validate_package_name(name: str, *, path: Path | None = None) -> str:
    """Return `name` if it can appear in a generated script, raise otherwise."""
    if not PACKAGE_NAME.fullmatch(name):
        raise WsbuildError(
            f"invalid package name {name!r}",
            path=path,
            hint="package names must match ^[a-z][a-z0-9_]*$",
        )
    return name


def validate_variable_name(name: str, *, path: Path | None = None, line: int | None = None) -> str:
    """Return `name` if it is a valid environment variable name, raise otherwise."""
    if not VARIABLE_NAME.fullmatch(name):
        raise WsbuildError(
            f"invalid environment variable name {name!r}",
            path=path,
            line=line,
            hint="names must match ^[A-Za-z_][A-Za-z0-9_]*$",
        )
    return name


def sh_quote(text: str) -> str:
    """Single-quote `text` for any POSIX shell (bash, dash, zsh); nothing in it is expanded."""
    return "'" + text.replace("'", "'\\''") + "'"


def prefixed_word(variable: str, relative: str) -> str:
    """A shell word for `$variable/relative` (or `$variable` alone), quoted so that
    `relative` is taken literally."""
    if not relative:
        return f'"${variable}"'
    if _PLAIN.fullmatch(relative):
        return f'"${variable}/{relative}"'
    return f'"${variable}"' + sh_quote("/" + relative)
