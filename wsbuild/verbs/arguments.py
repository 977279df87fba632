"""The arguments several verbs share: workspace, bases, scheduling and colcon's package
selection options, and their conversion into the records of `workspace/`; the values of the
pass-through options (`--cmake-args -DA=1`) collected before parsing."""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.errors import WsbuildError
from wsbuild.workspace.root import BUILD_BASE, INSTALL_BASE, LOG_BASE, Workspace

if TYPE_CHECKING:  # imported when a verb runs, not to parse its arguments
    from wsbuild.reporter import Terminal
    from wsbuild.workspace.selection import SelectionOptions

#: options whose values are handed through to another tool and may start with '-'
PASSTHROUGH = ("--cmake-args", "--pytest-args", "--ctest-args", "--ament-cmake-args",
               "--catkin-cmake-args", "--unittest-args")


def _passthrough_name(item: str, known: set[str] | None) -> str | None:
    """The pass-through option `item` spells: itself, or (with `known`, every long option)
    an abbreviation argparse would accept for it (`--cmake-arg`)."""
    if item in PASSTHROUGH:
        return item
    if known is None or not item.startswith("--") or "=" in item or len(item) < 4:
        return None
    matches = [name for name in known | set(PASSTHROUGH) if name.startswith(item)]
    return matches[0] if len(matches) == 1 and matches[0] in PASSTHROUGH else None


def collect_passthrough(argv: list[str], known: set[str]) -> list[str]:
    """`--cmake-args -DA=1 -DB=2` → `--cmake-args=-DA=1 --cmake-args=-DB=2`, as colcon allows.

    Values run until `--` or the next option wsbuild knows; a value starting with a space
    (`' --help'`) is one too, as in colcon.
    `known`: every long option of wsbuild's the command line may hold (cli.py's parser).
    """
    result: list[str] = []
    index = 0
    while index < len(argv):
        item = argv[index]
        index += 1
        name = _passthrough_name(item, known)
        if name is None:
            result.append(item)
            continue
        values = []
        while index < len(argv) and argv[index] != "--" and not _ends_values(argv[index], known):
            values.append(argv[index])
            index += 1
        if index < len(argv) and argv[index] == "--":
            index += 1
        result.extend(f"{name}={value}" for value in values)
        if not values:
            result.append(f"{name}=")
    return result


def _ends_values(item: str, known: set[str]) -> bool:
    """Whether `item` is an option of wsbuild's (another pass-through one too), which ends the
    values of a pass-through option."""
    return item.split("=")[0] in known or _passthrough_name(item, known) is not None


def may_pass_through(item: str) -> bool:
    """Whether `item` might be a pass-through option (cheap: no parser built)."""
    return item in PASSTHROUGH or (
        len(item) >= 5 and "=" not in item and any(p.startswith(item) for p in PASSTHROUGH))


def secondary(action: argparse.Action) -> argparse.Action:
    """Mark an option as rarely used: listed by --help-all, not by --help (cli.py's formatter)."""
    action.secondary = True  # type: ignore[attr-defined]
    return action


#: the selection options `--help` shows; --help-all lists the others too
COMMON_SELECTION = ("--packages-select", "--packages-skip", "--packages-up-to",
                    "--packages-above")


#: what --help says of the selection options it leaves out
MORE_SELECTION = ("also --packages-{select,skip,up-to,ignore}-regex, -above-and-dependencies, "
                  "-above-depth,\n-{select,skip}-by-dep, -skip-up-to, -ignore, -start, -end, "
                  "-select-build-failed, …: --help-all")


def add_workspace_arguments(parser: argparse.ArgumentParser, *,
                            selection: bool = True) -> argparse._ArgumentGroup:
    """-C/--workspace, --base-paths, --paths, and (with `selection`) colcon's --packages-*
    options; the group, for the selections other modules declare (cli.py adds them)."""
    if selection:
        group = parser.add_argument_group("workspace and packages (selection as in colcon)",
                                          MORE_SELECTION)
    else:
        group = parser.add_argument_group("workspace")
    add_workspace_option(group)
    group.add_argument("--base-paths", nargs="+", metavar="PATH",
                       help="where to look for packages (default: <workspace>/src)")
    secondary(group.add_argument("--paths", nargs="+", metavar="PATH",
                                 help="package directories, shell wildcards allowed (no "
                                      "crawling)"))
    if selection:
        add_selection_arguments(group)
    return group


def add_workspace_option(group: argparse._ActionsContainer, *, found: str = "the directory "
                         "above holding src/") -> None:
    group.add_argument("-C", "--workspace", metavar="DIR", dest="workspace_dir",
                       help=f"the workspace root (default: {found})")


def add_base_arguments(group: argparse._ActionsContainer, *, log_secondary: bool = True) -> None:
    """--build-base, --install-base, --log-base with colcon's defaults."""
    group.add_argument("--build-base", default=BUILD_BASE, metavar="DIR",
                       help=f"build directory, relative to the workspace (default: {BUILD_BASE})")
    add_install_base_argument(group, "install prefix, relative to the workspace")
    log = group.add_argument("--log-base", default=LOG_BASE, metavar="DIR",
                             help=f"log directory, relative to the workspace (default: {LOG_BASE})")
    if log_secondary:
        secondary(log)


def add_install_base_argument(group: argparse._ActionsContainer, what: str) -> None:
    group.add_argument("--install-base", default=INSTALL_BASE, metavar="DIR",
                       help=f"{what} (default: {INSTALL_BASE})")


def add_scheduling_arguments(group: argparse._ArgumentGroup, what: str) -> None:
    group.add_argument("--parallel-workers", type=int, metavar="N",
                       help=f"packages {what} at once (default: number of CPUs)")
    secondary(group.add_argument("--executor", choices=("parallel", "sequential"),
                                 default="parallel", help="sequential is --parallel-workers 1"))
    secondary(group.add_argument("--no-wait", action="store_true",
                                 help="fail at once if another wsbuild runs in this workspace "
                                      "(default: wait for it)"))


def add_selection_arguments(group: argparse._ActionsContainer) -> None:
    """The package selection options of colcon, shared by every verb that takes packages;
    those not in COMMON_SELECTION are left to --help-all."""

    def add(option: str, **kwargs: object) -> None:
        action = group.add_argument(option, **kwargs)  # type: ignore[arg-type]
        if option not in COMMON_SELECTION:
            secondary(action)

    add("--packages-select", nargs="*", metavar="PKG", help="only these packages")
    add("--packages-skip", nargs="*", metavar="PKG", help="leave these packages out")
    add("--packages-select-regex", nargs="*", metavar="PATTERN",
        help="only packages whose name matches a pattern (re.match)")
    add("--packages-skip-regex", nargs="*", metavar="PATTERN",
        help="leave out packages whose name matches a pattern")
    add("--packages-up-to", nargs="*", metavar="PKG",
        help="these packages and everything they depend on, recursively")
    add("--packages-up-to-regex", nargs="*", metavar="PATTERN",
        help="matching packages and everything they depend on, recursively")
    add("--packages-above", nargs="*", metavar="PKG",
        help="these packages and all that depend on them, recursively")
    add("--packages-above-and-dependencies", nargs="*", metavar="PKG",
        help="like --packages-above, plus the dependencies of all of those")
    add("--packages-above-depth", nargs="+", metavar=("DEPTH", "PKG"),
        help="these packages and their dependents up to DEPTH hops away")
    add("--packages-select-by-dep", nargs="*", metavar="DEP",
        help="only packages that (recursively) depend on DEP")
    add("--packages-skip-by-dep", nargs="*", metavar="DEP",
        help="leave out packages that (recursively) depend on DEP")
    add("--packages-skip-up-to", nargs="*", metavar="PKG",
        help="leave out these packages and everything they depend on")
    add("--packages-ignore", nargs="*", metavar="PKG",
        help="act as if these packages were not in the workspace")
    add("--packages-ignore-regex", nargs="*", metavar="PATTERN",
        help="act as if matching packages were not in the workspace")
    add("--packages-start", metavar="PKG",
        help="skip the packages before this one in topological order")
    add("--packages-end", metavar="PKG",
        help="skip the packages after this one in topological order")


#: selection fields where None (option not given) differs from an empty list
_OPTIONAL = ("packages_select", "packages_select_regex", "packages_start", "packages_end")


def selection_from_args(args: argparse.Namespace) -> SelectionOptions:
    """The --packages-* options of `args` (absent ones: not given)."""
    from dataclasses import fields

    from wsbuild.workspace.selection import SelectionOptions  # lazy: off `pkg create`

    values = {}
    for field in fields(SelectionOptions):
        value = getattr(args, field.name, None)
        if isinstance(value, list):
            value = tuple(value)
        if value is None and field.name not in _OPTIONAL:
            value = ()
        values[field.name] = value
    return SelectionOptions(**values)


@dataclass(frozen=True, slots=True)
class Bases:
    """--build-base, --install-base, --log-base as given (colcon's defaults otherwise)."""

    build_base: str = BUILD_BASE
    install_base: str = INSTALL_BASE
    log_base: str = LOG_BASE

    def workspace(self, root: Path) -> Workspace:
        """The workspace at `root` with these bases."""
        log_base = self.log_base
        if log_base == os.devnull:
            log_base = _discarded_log_base()
        return Workspace.at(root, build_base=self.build_base, install_base=self.install_base,
                            log_base=log_base)


def bases_from_args(args: argparse.Namespace) -> Bases:
    return Bases(build_base=getattr(args, "build_base", None) or BUILD_BASE,
                 install_base=getattr(args, "install_base", None) or INSTALL_BASE,
                 log_base=getattr(args, "log_base", None) or LOG_BASE)


def _discarded_log_base() -> str:
    """colcon's `--log-base /dev/null` (keep no logs): a temporary directory, deleted at exit
    (the run writes its logs as always, nothing stays)."""
    import atexit
    import shutil
    import tempfile

    path = tempfile.mkdtemp(prefix="wsbuild-log-")
    atexit.register(shutil.rmtree, path, ignore_errors=True)
    return path


def add_env_ignore_argument(group: argparse._ActionsContainer) -> None:
    """`--env-ignore`: the variables a user knows reach no build and no test (build, test)."""
    secondary(group.add_argument(
        "--env-ignore", nargs="+", action="extend", default=[], metavar="VAR",
        help="environment variables (names, or patterns with *) that reach no package's build "
             "or tests, beside wsbuild's own short list (the terminal's, CI's per-run ones); "
             "every other variable is compared, by digest. Set them once in a defaults file: "
             "build: {env-ignore: [MY_VAR]}"))


def env_ignore_from_args(args: argparse.Namespace) -> tuple[str, ...]:
    """The --env-ignore names and patterns, checked: letters, digits, _ and *."""
    import re

    names = tuple(getattr(args, "env_ignore", None) or ())
    for name in names:
        if not re.fullmatch(r"[A-Za-z_*][A-Za-z0-9_*]*", name):
            raise WsbuildError(f"--env-ignore: {name!r} is no environment variable name",
                               hint="give names like MY_TOKEN, or patterns like CI_*")
    return names


def terminal_from_args(args: argparse.Namespace) -> Terminal:
    """Where the verb's words go: the terminal cli.py made for this run (through the replay's
    recorder when the run is recorded), else the process's streams."""
    from wsbuild.reporter import Terminal  # lazy: off `build --help` and `pkg create --help`

    terminal = getattr(args, "terminal", None)
    return terminal if isinstance(terminal, Terminal) else Terminal.of(None)


def add_negations(parser: argparse.ArgumentParser) -> None:
    """Every on/off option `--X` of every verb gets `--no-X`, which turns it off again (a
    defaults file or a mixin that turned it on; the last one given wins). Not listed one by
    one in --help, which says so once."""
    for action in list(parser._actions):
        if isinstance(action, argparse._SubParsersAction):
            for sub in dict.fromkeys(action.choices.values()):
                add_negations(sub)
            continue
        if not isinstance(action, argparse._StoreTrueAction):
            continue
        for option in action.option_strings:
            if not option.startswith("--") or option.startswith("--no-"):
                continue
            negation = "--no-" + option[2:]
            if negation in parser._option_string_actions:
                continue
            parser.add_argument(negation, dest=action.dest, action="store_false",
                                help=argparse.SUPPRESS)
