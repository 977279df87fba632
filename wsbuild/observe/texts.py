"""The environment variables a shell or make reads, from the text it runs: both copy the whole
environment into their own variables at start, so no getenv shows which they use. What their
command line and the scripts and makefiles they read name (`$NAME`, `${NAME…}`, `$(NAME)`) is
what they read, with what a shell reads by itself (`PATH`, `IFS`, `HOME` for `~`, …); text that
names variables it builds at run time (`${!prefix*}`, `export -p`, `declare -p`, `compgen -v`,
`printenv`/`env`/`set` alone on a line) reads every variable."""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

from wsbuild.patterns import lazy

SHELLS = frozenset({"sh", "bash", "dash", "zsh", "ksh", "mksh", "ash", "busybox", "rbash"})
MAKES = frozenset({"make", "gmake", "remake"})
#: what a shell reads of the environment whatever its text says
SHELL_READS = ("PATH", "IFS", "CDPATH", "ENV", "BASH_ENV", "POSIXLY_CORRECT", "SHELLOPTS",
               "BASHOPTS", "GLOBIGNORE", "ZDOTDIR")
#: what make reads of the environment whatever its makefiles say
MAKE_READS = ("MAKEFLAGS", "MFLAGS", "MAKEFILES", "MAKELEVEL", "GNUMAKEFLAGS", "MAKE_RESTARTS")

_SHELL_NAME = lazy(r"\$\{?([A-Za-z_][A-Za-z0-9_]*)")
_MAKE_NAME = lazy(r"\$[({]([A-Za-z_][A-Za-z0-9_]*)[)}:]")
_EVERY = lazy(r"\$\{!|\bexport\s+-p\b|\bdeclare\s+-[a-zA-Z]*p\b|\bcompgen\s+-v\b|"
                    r"^\s*(?:set|env|printenv|export|declare|typeset)\s*(?:[;|&]|$)",
                    re.MULTILINE)


@dataclass(frozen=True, slots=True)
class TextReads:
    """The variables a shell's or make's text names (`every`: it may read any)."""

    names: frozenset[str]
    every: bool


def shell_reads(texts: Iterable[str]) -> TextReads:
    names: set[str] = set(SHELL_READS)
    every = False
    for text in texts:
        names.update(_SHELL_NAME.findall(text))
        if "~" in text:
            names.add("HOME")
        if _EVERY.search(text):
            every = True
    return TextReads(frozenset(names), every)


def make_reads(texts: Iterable[str]) -> TextReads:
    names: set[str] = set(MAKE_READS)
    for text in texts:
        names.update(_MAKE_NAME.findall(text))
    return TextReads(frozenset(names), False)
