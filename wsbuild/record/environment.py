"""Which environment variables a package's record holds, and how: every variable but a short
list of those that cannot reach a build's output, each by a digest of its value (a value is
never written down).

Left out (`NOT_INPUTS`, names or fnmatch patterns; a user adds more with `not-inputs:` in the
defaults file, verbs/defaults.py):
- what a terminal or login session sets for itself: the shell's per-command variables, the
  terminal's size and kind, the multiplexer's and the SSH agent's sockets;
- the identifiers a CI system or a test runner gives each run, job or test (GitHub Actions,
  GitLab CI, Jenkins, Buildkite, CircleCI, Azure Pipelines, pytest), which differ every time;
- wsbuild's own settings (`WSBUILD_*`): what of them reaches a build (the cache, the oracle)
  does so through options the record holds by themselves.

Normalized before the digest: entries of a path list that lie in the workspace's own install
base are dropped (sourcing `install/setup.bash` adds them; what a build reads there is its
dependencies', which the record holds by their records), and a variable left empty by that
counts as unset; `LD_LIBRARY_PATH` counts as the set of its directories (the ROS wheels'
bootstrapper adds its own in a different order in every process).

`SHARED` names the variables that differ from machine to machine and user to user but are
still compared on this machine: they stay out of the key a build cache entry is found by, so
two users of one checkout path share entries, and a restore names those that differed
("restored; built where HOME differed")."""

from __future__ import annotations

import fnmatch
import functools
import hashlib
import os
import re
from collections.abc import Iterable, Mapping

#: variables that cannot reach a build's output (names, or fnmatch patterns with `*`)
NOT_INPUTS: tuple[str, ...] = (
    # the shell and the terminal
    "_", "OLDPWD", "PWD", "SHLVL", "TERM", "COLORTERM", "COLUMNS", "LINES", "LS_COLORS",
    "PS1", "PS2", "PROMPT_COMMAND", "HISTFILE", "HISTSIZE", "HISTFILESIZE", "HISTCONTROL",
    "TERM_PROGRAM", "TERM_PROGRAM_VERSION", "TERM_SESSION_ID", "VTE_VERSION", "WINDOWID",
    "TMUX", "TMUX_PANE", "STY", "LESSOPEN", "LESSCLOSE", "MOTD_SHOWN",
    # the login session and its agents
    "SSH_AUTH_SOCK", "SSH_AGENT_PID", "SSH_CLIENT", "SSH_CONNECTION", "SSH_TTY",
    "GPG_AGENT_INFO", "DBUS_SESSION_BUS_ADDRESS", "XDG_SESSION_*", "XDG_SEAT", "XDG_VTNR",
    "INVOCATION_ID", "JOURNAL_STREAM", "MAIL",
    # CI systems' identifiers of a run, a job or a step, and their per-run tokens and files
    "GITHUB_RUN_*", "GITHUB_JOB", "GITHUB_ACTION", "GITHUB_ACTION_PATH", "GITHUB_ENV",
    "GITHUB_OUTPUT", "GITHUB_STATE", "GITHUB_STEP_SUMMARY", "GITHUB_PATH", "GITHUB_TOKEN",
    "ACTIONS_RUNTIME_*", "ACTIONS_ID_TOKEN_*", "ACTIONS_CACHE_URL", "ACTIONS_RESULTS_URL",
    "CI_JOB_*", "CI_PIPELINE_*", "CI_BUILD_*", "CI_CONCURRENT_*", "CI_NODE_*",
    "BUILD_NUMBER", "BUILD_ID", "BUILD_TAG", "BUILD_URL", "BUILD_DISPLAY_NAME", "JOB_URL",
    "RUN_DISPLAY_URL", "RUN_ARTIFACTS_DISPLAY_URL", "RUN_CHANGES_DISPLAY_URL",
    "RUN_TESTS_DISPLAY_URL", "EXECUTOR_NUMBER", "JENKINS_SERVER_COOKIE", "HUDSON_SERVER_COOKIE",
    "BUILDKITE_BUILD_*", "BUILDKITE_JOB_ID", "BUILDKITE_AGENT_ACCESS_TOKEN",
    "CIRCLE_BUILD_*", "CIRCLE_WORKFLOW_*", "CIRCLE_NODE_INDEX",
    "BUILD_BUILDID", "BUILD_BUILDNUMBER", "SYSTEM_JOBID", "SYSTEM_TIMELINEID",
    "SYSTEM_ACCESSTOKEN",
    # a test runner's name for the current test and worker (wsbuild run inside pytest)
    "PYTEST_CURRENT_TEST", "PYTEST_XDIST_*",
    # wsbuild's own settings: what of them shapes a build is an option of the record
    "WSBUILD_*",
)

#: variables that differ between machines and users: compared here, left out of the key a
#: shared build cache entry is found by, and named when a restored entry was built with
#: another value
SHARED: tuple[str, ...] = (
    "HOME", "USER", "LOGNAME", "USERNAME", "HOSTNAME", "SUDO_USER", "SUDO_UID", "SUDO_GID",
    "SUDO_COMMAND", "XDG_RUNTIME_DIR", "XDG_CONFIG_HOME", "XDG_CACHE_HOME", "XDG_DATA_HOME",
    "XDG_STATE_HOME", "TMPDIR", "DISPLAY", "WAYLAND_DISPLAY",
    "RUNNER_NAME", "RUNNER_TEMP", "RUNNER_TOOL_CACHE", "RUNNER_WORKSPACE", "RUNNER_TRACKING_ID",
    "CI_RUNNER_*", "CI_SERVER_*", "NODE_NAME", "AGENT_NAME", "AGENT_ID", "BUILDKITE_AGENT_*",
)

#: path lists whose directory order no build depends on (set order in each process)
UNORDERED = frozenset({"LD_LIBRARY_PATH"})


@functools.lru_cache(maxsize=16)
def _pattern(patterns: tuple[str, ...]) -> re.Pattern[str]:
    return re.compile("|".join(fnmatch.translate(p) for p in patterns) or r"(?!)")


def matches(name: str, patterns: Iterable[str]) -> bool:
    """Whether `name` is one of `patterns` (an exact name, or an fnmatch pattern with `*`)."""
    return _pattern(tuple(patterns)).match(name) is not None


def _digest(value: str) -> str:
    return hashlib.blake2b(value.encode("utf-8", "surrogateescape"), digest_size=8).hexdigest()


def normalized(name: str, value: str, own: str) -> str | None:
    """The value as the record compares it: the path-list entries in `own` (the workspace's
    install base, with a trailing separator) dropped, LD_LIBRARY_PATH as a set; None when
    nothing is left of a value that had entries there."""
    if own and own.rstrip(os.sep) in value:
        entries = value.split(os.pathsep)
        kept = [e for e in entries if not (e + os.sep).startswith(own)]
        if len(kept) != len(entries):
            if not any(kept):
                return None
            value = os.pathsep.join(kept)
    if name in UNORDERED:
        value = os.pathsep.join(sorted(set(value.split(os.pathsep))))
    return value


def environment_digests(environ: Mapping[str, str], *, own_install: str = "",
                        not_inputs: Iterable[str] = ()) -> dict[str, str]:
    """name -> digest of every variable of `environ` that can reach a build (sorted by name):
    all but `NOT_INPUTS` and the user's `not_inputs`, normalized (`own_install`: the
    workspace's install base)."""
    skipped = (*NOT_INPUTS, *not_inputs)
    own = own_install.rstrip(os.sep) + os.sep if own_install else ""
    digests: dict[str, str] = {}
    for name in sorted(environ):
        if matches(name, skipped):
            continue
        value = normalized(name, environ[name], own)
        if value is not None:
            digests[name] = _digest(value)
    return digests


def keyed(environment: Mapping[str, str]) -> dict[str, str]:
    """The digests a shared cache entry is found by: all but the `SHARED` variables."""
    return {name: digest for name, digest in environment.items() if not matches(name, SHARED)}


def changed_names(old: Mapping[str, str], new: Mapping[str, str]) -> list[str]:
    """The variables set, unset or changed between two records' digests, sorted."""
    return sorted(name for name in set(old) | set(new) if old.get(name) != new.get(name))
