"""After the packages of a build: the workspace's setup scripts, the merged
compile_commands.json, and the linters that were stood in for, named once."""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path

from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.files import write_if_changed
from wsbuild.events import Emit, Notice
from wsbuild.underlay.environment import BOOTSTRAP_GUARD_VAR, PreparedUnderlay, build_environment
from wsbuild.underlay.lint import stand_ins_used
from wsbuild.workspace.root import Workspace
from wsbuild import inputs
from wsbuild.prefix import ChainedUnderlay, underlays_from_environment, write_workspace_scripts


#: what the workspace's setup scripts were last written from (a no-op rewrites nothing)
SETUP_INPUTS = Path(".wsbuild") / "setup_inputs.json"


def write_setup_scripts(ws: Workspace, merged: bool, underlay: PreparedUnderlay, *,
                        installed_changed: bool) -> None:
    """Write install/setup.* and local_setup.* for every package installed so far; when no
    package was installed in this run and the chained underlays are the ones they were
    written for, they are current already and nothing is read or written."""
    # chain what was sourced before the venv was applied, then the venv itself
    underlays = underlays_from_environment(os.environ, ws.install_base)
    if underlay.venv is not None:
        # with the library path set, the wheels' bootstrapper need not re-execute every Python
        underlays.append(ChainedUnderlay(prefix=underlay.venv, script_dir=None,
                                         prepend=venv_prepends(underlay.venv),
                                         set=((BOOTSTRAP_GUARD_VAR, "1"),)))
    wanted = json.dumps({"merged": merged, "underlays": [repr(u) for u in underlays]})
    memo = ws.build_base / SETUP_INPUTS
    if not installed_changed and _read(memo) == wanted and all(
            inputs.is_file(ws.install_base / f"{name}.bash") for name in ("setup", "local_setup")):
        return
    write_workspace_scripts(ws.install_base, merged=merged, underlays=underlays)
    try:
        memo.parent.mkdir(parents=True, exist_ok=True)
        memo.write_text(wanted)
    except OSError:
        pass  # next time they are written again


def _read(path: Path) -> str | None:
    try:
        return inputs.read_text(path)
    except OSError:
        return None


def venv_prepends(venv: Path) -> tuple[tuple[str, str], ...]:
    """(VAR, entry) pairs that make a shell see the venv underlay as a build did.

    Computed against an empty environment: wsbuild's own environment already holds what the
    wheels' bootstrapper added when it re-executed wsbuild."""
    full = build_environment(venv, {})
    result: list[tuple[str, str]] = []
    for var in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "LD_LIBRARY_PATH", "PATH"):
        # the last pair of a variable ends up first
        result += [(var, entry) for entry in reversed(full.get(var, "").split(os.pathsep))
                   if entry]
    return tuple(result)


def name_lint_stand_ins(ws: Workspace, results: Sequence[JobResult], emit: Emit) -> None:
    """One line naming the linters stood in for (not installed) in the packages built now."""
    built = [ws.build_base / r.package for r in results if r.outcome is Outcome.FINISHED]
    used = stand_ins_used(built)
    if used:
        names = ", ".join(f"{linter} ({len(users)} package{'s' if len(users) > 1 else ''})"
                          for linter, users in used.items())
        emit(Notice(f"linters not installed, stood in for (their tests not registered): {names}"))


def merge_compile_commands(ws: Workspace) -> None:
    """build/compile_commands.json: every package's entries, for editors and clangd."""
    entries: list[object] = []
    for path in sorted(ws.build_base.glob("*/compile_commands.json")):
        try:
            entries.extend(json.loads(path.read_text()))
        except (OSError, ValueError):
            continue
    target = ws.build_base / "compile_commands.json"
    if not entries:
        return
    write_if_changed(target, json.dumps(entries, indent=2) + "\n")
