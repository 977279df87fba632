"""The environment every build and test step starts from, and what observing it adds.

A step gets the user's environment (the underlay's and its dependencies' hooks applied by the
caller) less what a terminal or a login shell sets for itself, and a fixed locale: those
change from one terminal tab or editor window to the next (GNOME Terminal, VS Code and tmux set
some per tab), so building from two terminals must not make two different builds. What a step
then reads of the rest is observed (observe/log.py) and only that is an input of its record.

Left out of every step (`NOT_PASSED`, fnmatch patterns):
- the shell's per-command variables (`_`, `OLDPWD`, `PWD`, `SHLVL`): a shell a step starts
  sets its own;
- the terminal's kind, identity and size (`TERM`, `TERM_PROGRAM*`, `TERM_SESSION_ID`, `COLORTERM`,
  `VTE_VERSION`, `WINDOWID`, `COLUMNS`, `LINES`, `GNOME_TERMINAL_*`, `KONSOLE_*`, `ITERM_*`,
  `WT_SESSION`, `TMUX`, `TMUX_PANE`, `STY`), an editor's terminal (`VSCODE_*`), the prompt
  and history (`PS1`…, `PROMPT_COMMAND`, `HIST*`), the colours of `ls` and `less`'s helpers.
  A step's output goes to a pipe, never a terminal: compilers and Ninja read `TERM` only to
  colour what they print there.

The locale (`LANG`, `LANGUAGE`, `LC_*`) is fixed: every step gets `LANG=C.UTF-8` and no other
locale variable, as Bazel's strict action environment does. Compilers, CMake and Python read
the locale for their messages and their text encoding; fixed, a `LANG` that differs between
two shells builds nothing again, and every log reads the same (in English).

Observing adds, for the step only (never printed, never recorded): the interposed library
(`LD_PRELOAD`, before any the user preloads), where to write (`WSOBSERVE_DIR`) and the Python
hook's directory (first on `PYTHONPATH`)."""

from __future__ import annotations

import fnmatch
import os
import re
from collections.abc import Mapping
from pathlib import Path

from wsbuild.observe.library import Observer
from wsbuild.terminal import PER_TAB

#: what no step gets (see the module's docstring)
NOT_PASSED: tuple[str, ...] = (
    *PER_TAB, "PWD",
    "TERM", "TERM_PROGRAM", "TERM_PROGRAM_VERSION", "COLORTERM", "VTE_VERSION",
    "COLUMNS", "LINES", "LS_COLORS", "LESSOPEN", "LESSCLOSE",
)
#: the locale every step gets, and the variables that would choose another
LOCALE = "C.UTF-8"
LOCALE_VARIABLES: tuple[str, ...] = ("LANG", "LANGUAGE", "LC_*")

#: what observing a step sets: never an input of its record
OBSERVER_VARIABLES = ("LD_PRELOAD", "WSOBSERVE_DIR", "WSOBSERVE_QUIET")

_LEFT_OUT = re.compile("|".join(fnmatch.translate(p) for p in (*NOT_PASSED, *LOCALE_VARIABLES)))


def step_base(environ: Mapping[str, str]) -> dict[str, str]:
    """`environ` as a step gets it: without `NOT_PASSED` and with the fixed locale."""
    base = {name: value for name, value in environ.items() if not _LEFT_OUT.match(name)}
    base["LANG"] = LOCALE
    return base


def observed(environ: Mapping[str, str], observer: Observer, log_dir: Path) -> dict[str, str]:
    """`environ` with what makes the step's processes write down what they read into
    `log_dir`."""
    env = dict(environ)
    preload = env.get("LD_PRELOAD", "")
    env["LD_PRELOAD"] = f"{observer.library} {preload}".strip() if preload else str(
        observer.library)
    env["WSOBSERVE_DIR"] = str(log_dir)
    env.pop("WSOBSERVE_QUIET", None)
    python_path = env.get("PYTHONPATH", "")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(observer.hook_dir), python_path)))
    return env


def unobserved(name: str, value: str, observer: Observer | None) -> str | None:
    """A variable's value as the step would have had it without observing (None: it would
    not have been set at all): what its record holds."""
    if name in ("WSOBSERVE_DIR", "WSOBSERVE_QUIET"):
        return None
    if observer is None:
        return value
    if name == "LD_PRELOAD":
        rest = " ".join(part for part in value.replace(":", " ").split()
                        if part != str(observer.library))
        return rest or None
    if name == "PYTHONPATH":
        rest = os.pathsep.join(part for part in value.split(os.pathsep)
                               if part != str(observer.hook_dir))
        return rest or None
    return value
