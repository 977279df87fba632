"""Workspace setup scripts: static local_setup.* and chaining setup.* for sh, bash and zsh."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from wsbuild import inputs
from wsbuild.files import write_if_changed
from wsbuild.prefix.dsv import Action, Operation, PackageEnvironment, resolve_package
from wsbuild.prefix.layout import (
    INSTALL_LAYOUT_MARKER,
    ISOLATED,
    mark_install_layout,
    order_packages,
    package_prefix,
    read_installed_packages,
    write_ignore_marker,
)
from wsbuild.prefix.quoting import prefixed_word, sh_quote, validate_variable_name
from wsbuild.prefix.render import render

#: the shells wsbuild writes setup scripts for (colcon-core's sh, colcon-bash, colcon-zsh)
SHELLS = ("sh", "bash", "zsh")


@dataclass(frozen=True, slots=True)
class ChainedUnderlay:
    """An underlay active at build time that `setup.*` re-applies before this workspace.

    `script_dir` holds `local_setup.{sh,bash,zsh}` to source with COLCON_CURRENT_PREFIX set
    to `prefix` (a colcon/ament workspace, /opt/ros/<distro>). `prepend` lists
    (VARIABLE, value) pairs to prepend without duplicates, in order, for an underlay without
    scripts (a ROS virtualenv from PyPI); the last pair of a variable ends up first.
    `set` lists (VARIABLE, value) pairs exported as they are, after the prepends.
    """

    prefix: Path
    script_dir: Path | None = None
    prepend: tuple[tuple[str, str], ...] = ()
    set: tuple[tuple[str, str], ...] = ()


def underlays_from_environment(environ: Mapping[str, str], install_base: Path) -> list[ChainedUnderlay]:
    """The chain colcon records in setup.*: highest priority first, this install base excluded.

    COLCON_PREFIX_PATH entries come first, then AMENT_PREFIX_PATH entries holding a
    `local_setup.*`; an AMENT_PREFIX_PATH entry inside an isolated colcon install stands for
    that install base (colcon-ros's ament prefix path extension). Missing paths are skipped.
    """
    paths: list[str] = []
    for path in environ.get("COLCON_PREFIX_PATH", "").split(os.pathsep):
        if path and inputs.exists(path):
            paths.append(path)
    for path in environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if not path or not inputs.exists(path):
            continue
        try:
            names = inputs.listdir(path)
        except OSError:
            continue
        if any(name.startswith("local_setup.") for name in names):
            paths.append(path)
            continue
        parent = os.path.dirname(path.rstrip("/"))
        try:
            layout = inputs.read_text(Path(parent, INSTALL_LAYOUT_MARKER)).rstrip()
        except OSError:
            continue
        if layout == ISOLATED:
            paths.append(parent)
    own = {str(install_base), os.path.realpath(install_base)}
    underlays: list[ChainedUnderlay] = []
    seen: set[str] = set()
    for path in paths:
        real = os.path.realpath(path)
        if path in own or real in own or real in seen:
            continue
        seen.add(real)
        underlays.append(ChainedUnderlay(prefix=Path(path), script_dir=Path(path)))
    return underlays


def write_workspace_scripts(
    install_base: Path, *, merged: bool, underlays: Sequence[ChainedUnderlay] | None
) -> list[Path]:
    """Write install/{local_setup,setup}.{sh,bash,zsh} and the install markers.

    `local_setup.*` applies every installed package (found through
    `share/colcon-core/packages`) in dependency order, with each package.dsv already
    interpreted: sourcing it runs no Python and starts no process. `setup.*` first sources
    the `underlays` (given highest priority first, applied lowest first, as colcon does),
    then `local_setup.*`; `underlays=None` keeps existing `setup.*` as they are (`wsbuild
    clean` removing packages). Also writes `.colcon_install_layout` (raising if the install
    base has the other layout) and `COLCON_IGNORE`. Returns the paths actually written.
    """
    install_base.mkdir(parents=True, exist_ok=True)
    written = [p for p in (mark_install_layout(install_base, merged=merged),
                           write_ignore_marker(install_base)) if p is not None]
    packages = read_installed_packages(install_base, merged=merged)
    environments = [
        (package, resolve_package(package_prefix(install_base, package, merged=merged), package))
        for package in order_packages(packages)
    ]
    build_prefix = sh_quote(os.path.abspath(install_base))
    for shell in SHELLS:
        files = {
            install_base / f"local_setup.{shell}": _local_setup(
                install_base, environments, merged=merged, shell=shell, build_prefix=build_prefix
            ),
        }
        setup = install_base / f"setup.{shell}"
        if underlays is not None or not setup.exists():
            files[setup] = _setup(underlays or (), shell=shell, build_prefix=build_prefix)
        written += [path for path, content in files.items() if write_if_changed(path, content)]
    return written


def _local_setup(
    install_base: Path,
    environments: list[tuple[str, PackageEnvironment]],
    *,
    merged: bool,
    shell: str,
    build_prefix: str,
) -> str:
    body = _local_setup_body(install_base, environments, merged=merged, shell=shell)
    values = {
        "HEADER": render("local_setup_header.txt", COUNT=str(len(environments))),
        "FUNCTIONS": render("local_setup_functions.sh"),
        "BODY": body,
    }
    if shell == "sh":
        values["BUILD_PREFIX"] = build_prefix
    elif shell == "bash":
        values["ABSPATH"] = render("abspath.bash", FUNC="_wsb_ls_abspath")
    return render(f"local_setup.{shell}", **values)


def _local_setup_body(
    install_base: Path, environments: list[tuple[str, PackageEnvironment]], *, merged: bool, shell: str
) -> str:
    lines = [
        "# add this prefix to the COLCON_PREFIX_PATH",
        '_wsb_ls_prepend COLCON_PREFIX_PATH "${COLCON_PREFIX_PATH-}" "$_wsb_ls_prefix"',
    ]
    if environments:
        lines += ["", "# packages in dependency order: " + " ".join(p for p, _ in environments)]
    batch = _Batch()
    sources = 0
    for package, environment in environments:
        prefix = package_prefix(install_base, package, merged=merged)
        # values are written relative to the prefix found when sourcing
        subdirectory = "" if merged else package
        for operation in environment.operations:
            if operation.action is not Action.SOURCE:
                batch.add(operation, str(prefix), subdirectory)
                continue
            script = operation.script_for(None if shell == "sh" else shell)
            if script is None:
                continue
            # a sourced script may read or change anything: apply what came before it first
            lines += batch.flush()
            sources += 1
            lines += [
                "",
                f"# {package}: a script without a .dsv description",
                f"COLCON_CURRENT_PREFIX={prefixed_word('_wsb_ls_prefix', subdirectory)}",
                f"_wsb_ls_source {_word(replace(operation, value=script), subdirectory)}",
            ]
    lines += batch.flush()
    if sources:
        # hook scripts get COLCON_CURRENT_PREFIX; give the caller's value back afterwards
        lines[:0] = [
            "_wsb_ls_ccp_set=${COLCON_CURRENT_PREFIX+x}",
            '_wsb_ls_ccp="${COLCON_CURRENT_PREFIX-}"',
        ]
        lines += [
            "",
            'if [ -n "$_wsb_ls_ccp_set" ]; then',
            '  COLCON_CURRENT_PREFIX="$_wsb_ls_ccp"',
            "else",
            "  unset COLCON_CURRENT_PREFIX",
            "fi",
            "unset _wsb_ls_ccp_set _wsb_ls_ccp",
        ]
    return "\n".join(lines) + "\n"


def _word(operation: Operation, subdirectory: str) -> str:
    """The shell word for an operation's value: relative to `$_wsb_ls_prefix/<subdirectory>`
    (the package prefix), or a quoted literal."""
    if not operation.relative:
        return sh_quote(operation.value)
    relative = "/".join(part for part in (subdirectory, operation.value) if part)
    return prefixed_word("_wsb_ls_prefix", relative)


class _Batch:
    """Operations between two sourced scripts, applied with one shell call per run.

    Only each variable's own operations depend on each other, so they are grouped by
    variable (keeping their order). A value already added to a variable is dropped, as
    colcon's prefix_util does; consecutive prepends (appends) of values inside the prefix
    become one call listing them in their final order.
    """

    def __init__(self) -> None:
        self._operations: dict[str, list[tuple[Action, bool, str]]] = {}
        self._added: set[tuple[str, str, bool]] = set()

    def add(self, operation: Operation, prefix: str, subdirectory: str) -> None:
        name = operation.name
        if operation.action in (Action.PREPEND, Action.APPEND):
            key = (name, operation.resolve(prefix), operation.relative)
            if key in self._added:
                return
            self._added.add(key)
        else:
            self._added = {key for key in self._added if key[0] != name}
        self._operations.setdefault(name, []).append(
            (operation.action, operation.relative, _word(operation, subdirectory))
        )

    def flush(self) -> list[str]:
        lines: list[str] = []
        for name, operations in self._operations.items():
            lines += ["", f"# {name}"]
            index = 0
            while index < len(operations):
                action, relative, word = operations[index]
                if action is Action.SET:
                    lines.append(f"export {name}={word}")
                elif action is Action.SET_IF_UNSET:
                    lines.append(f'if [ -z "${{{name}:-}}" ]; then export {name}={word}; fi')
                else:
                    words = [word]
                    while index + 1 < len(operations) and operations[index + 1][:2] == (action, relative):
                        index += 1
                        words.append(operations[index][2])
                    if action is Action.PREPEND:
                        # each value goes in front of the previous ones
                        words.reverse()
                    function = "_wsb_ls_prepend" if action is Action.PREPEND else "_wsb_ls_append"
                    if not relative:
                        function += "_checked"
                    lines.append(f'{function} {name} "${{{name}-}}" \\')
                    lines += [f"  {w} \\" for w in words[:-1]] + [f"  {words[-1]}"]
                index += 1
        self._operations = {}
        self._added = set()
        return lines


def _setup(underlays: Sequence[ChainedUnderlay], *, shell: str, build_prefix: str) -> str:
    ext = "sh" if shell == "sh" else shell
    lines: list[str] = []
    for number, underlay in enumerate(reversed(underlays), start=1):
        # paths never go into comments: a newline in one would end the comment
        lines.append(f"# underlay {number} of {len(underlays)}")
        if underlay.script_dir is not None:
            lines.append(
                f"_wsb_setup_source {sh_quote(str(underlay.prefix))} {sh_quote(str(underlay.script_dir))}"
            )
        for name, value in underlay.prepend:
            validate_variable_name(name)
            lines.append(f'_wsb_setup_prepend {name} "${{{name}-}}" {sh_quote(value)}')
        for name, value in underlay.set:
            validate_variable_name(name)
            lines.append(f"export {name}={sh_quote(value)}")
        lines.append("")
    values = {
        "HEADER": render("setup_header.txt"),
        "FUNCTIONS": render("setup_functions.sh", EXT=ext),
        "UNDERLAYS": "\n".join(lines),
    }
    if shell == "sh":
        values["BUILD_PREFIX"] = build_prefix
    elif shell == "bash":
        values["ABSPATH"] = render("abspath.bash", FUNC="_wsb_setup_abspath")
    return render(f"setup.{shell}", **values)
