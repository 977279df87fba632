"""What a terminal, an editor and a shell set for themselves, per tab, window and command: the
variables that say which one this is (`PER_TAB`), which neither wsbuild nor a step it starts
reads. No step gets them (observe/step_environment.py), and a replay's key leaves them out
(engine/replay.py): building from another tab of the same shell is the same build, answered
from the same recording."""

from __future__ import annotations

import re

from wsbuild.patterns import lazy

#: fnmatch-like patterns (a trailing `*`) of the variables that name this tab, window or command
PER_TAB: tuple[str, ...] = (
    "_", "OLDPWD", "SHLVL",
    "TERM_SESSION_ID", "WINDOWID", "GNOME_TERMINAL_*", "KONSOLE_*", "ITERM_*", "WT_SESSION",
    "WT_PROFILE_ID", "TMUX", "TMUX_PANE", "STY", "VSCODE_*",
    "PS1", "PS2", "PS4", "PROMPT_COMMAND", "HISTFILE", "HISTSIZE", "HISTFILESIZE",
    "HISTCONTROL", "MOTD_SHOWN",
)

_PER_TAB = lazy("|".join(
    re.escape(p[:-1]) + ".*" if p.endswith("*") else re.escape(p) for p in PER_TAB) + r"\Z")


def is_per_tab(name: str) -> bool:
    """Whether the variable `name` names the terminal tab, window or command (`PER_TAB`)."""
    return _PER_TAB.match(name) is not None
