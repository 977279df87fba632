"""Shell completion through argcomplete: verbs, options, and the workspace's package names."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Iterable
from pathlib import Path

from wsbuild.verbs.colcon import EVENT_HANDLERS
from wsbuild.verbs.mixin import known_mixins
from wsbuild.workspace.root import INSTALL_BASE, Workspace, find_workspace_root
from wsbuild.patterns import lazy

COMPLETION_DOC = """Print shell code: Tab then completes verbs, options and package names.

Add the line for your shell to its rc file (~/.bashrc or ~/.zshrc), then open a new shell:
  eval "$(wsbuild completion bash)"
  eval "$(wsbuild completion zsh)"

Package names come from a quick crawl of the workspace found from the current directory
(or -C). The code comes from argcomplete, which wsbuild depends on.
"""

SHELLS = ("bash", "zsh")
#: metavars of the arguments that take package names (selection options, `info`, `run`)
_PACKAGE_METAVARS = ("PKG", "DEP")
_NAME_RE = lazy(rb"<name>\s*([^<\s]+)\s*</name>")


def add_completion_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("shell", choices=SHELLS, help="the shell to print the code for")


def run_completion(args: argparse.Namespace) -> int:
    """Print the shell code registering wsbuild's completion."""
    from argcomplete import shellcode

    print(shellcode(["wsbuild"], shell=args.shell), end="")
    return 0


def workspace_package_names(root: Path, base_paths: Iterable[Path] | None = None) -> list[str]:
    """The names of the packages under `root`/src (or `base_paths`), from a crawl that reads
    only each package.xml's <name> (no parsing, no graph): instant also on 1,000 packages."""
    from wsbuild.workspace.discover import find_package_dirs  # lazy: off `completion`

    workspace = Workspace.at(root)
    bases = list(base_paths) if base_paths else workspace.default_base_paths()
    names: set[str] = set()
    skip = [workspace.build_base, workspace.install_base, workspace.log_base]
    for directory in find_package_dirs(bases, skip):
        try:
            with open(f"{directory}/package.xml", "rb") as handle:
                match = _NAME_RE.search(handle.read(65536))
        except OSError:
            match = None
        # a plain CMake/Python package without package.xml: its directory name is the best
        # cheap guess (the real name comes from project()/setup(), which is not worth parsing)
        names.add(match.group(1).decode(errors="replace") if match else directory.name)
    return sorted(names)


def _package_completer(prefix: str, parsed_args: argparse.Namespace,
                       **_kwargs: object) -> list[str]:
    given = getattr(parsed_args, "workspace_dir", None)
    root = Path(given).absolute() if given else find_workspace_root(Path.cwd())
    bases = [Path(p).absolute() for p in getattr(parsed_args, "base_paths", None) or []]
    return [n for n in workspace_package_names(root, bases or None) if n.startswith(prefix)]


def _executable_completer(prefix: str, parsed_args: argparse.Namespace,
                          **_kwargs: object) -> list[str]:
    """`wsbuild run PKG <Tab>`: the executables in install/PKG/lib/PKG/ (or a merged install)."""
    package = getattr(parsed_args, "package_name", None)
    if not package:
        return []
    given = getattr(parsed_args, "workspace_dir", None)
    root = Path(given).absolute() if given else find_workspace_root(Path.cwd())
    install = root / (getattr(parsed_args, "install_base", None) or INSTALL_BASE)
    found: list[str] = []
    for lib in (install / package / "lib" / package, install / "lib" / package):
        try:
            found += [e.name for e in os.scandir(lib)
                      if e.is_file() and os.access(e.path, os.X_OK)]
        except OSError:
            continue
    return sorted(n for n in set(found) if n.startswith(prefix))


def _takes_packages(action: argparse.Action) -> bool:
    metavar = action.metavar
    if isinstance(metavar, tuple):
        return any(m in _PACKAGE_METAVARS for m in metavar)
    return metavar in _PACKAGE_METAVARS


#: the values of `-DCMAKE_BUILD_TYPE=` (CMake's own)
CMAKE_CONFIGURATIONS = ("Debug", "Release", "RelWithDebInfo", "MinSizeRel")
#: the defines people give --cmake-args most, completed after `-D`
CMAKE_DEFINES = ("-DCMAKE_BUILD_TYPE=", "-DBUILD_TESTING=", "-DCMAKE_EXPORT_COMPILE_COMMANDS=",
                 "-DCMAKE_CXX_STANDARD=", "-DCMAKE_VERBOSE_MAKEFILE=")


def _cmake_args_completer(prefix: str, **_kwargs: object) -> list[str]:
    """`--cmake-args -DCMAKE_BUILD_TYPE=<Tab>`: CMake's build types; `-D<Tab>`: the common
    defines."""
    name, equals, _value = prefix.partition("=")
    if equals and name == "-DCMAKE_BUILD_TYPE":
        values = [f"{name}={kind}" for kind in CMAKE_CONFIGURATIONS]
    elif equals:
        values = [f"{name}={value}" for value in ("ON", "OFF")]
    else:
        values = list(CMAKE_DEFINES)
    return [v for v in values if v.startswith(prefix)]


def _mixin_completer(prefix: str, parsed_args: argparse.Namespace,
                     **_kwargs: object) -> list[str]:
    """`--mixin <Tab>`: the mixins of the verb from the mixin files (colcon-mixin's)."""
    verb = getattr(parsed_args, "verb", None) or "build"
    try:
        names = known_mixins(os.environ).get(verb, {})
    except Exception:  # noqa: BLE001 - a bad mixin file completes nothing, the run says why
        return []
    return sorted(n for n in names if n.startswith(prefix))


def _event_handler_completer(prefix: str, **_kwargs: object) -> list[str]:
    """`--event-handlers <Tab>`: each handler, on (+) and off (-)."""
    return [f"{name}{sign}" for name in sorted(EVENT_HANDLERS) for sign in "+-"
            if f"{name}{sign}".startswith(prefix)]


def _build_type_completer(prefix: str, **_kwargs: object) -> list[str]:
    """`pkg create --build-type <Tab>`: the build types wsbuild knows."""
    from wsbuild.build_types import KnownBuildTypes  # lazy: off `completion`

    return sorted(n for n in KnownBuildTypes() if n.startswith(prefix))


#: the options that take a value of a kind wsbuild can list
_VALUE_COMPLETERS: dict[str, Callable[..., list[str]]] = {
    "--cmake-args": _cmake_args_completer, "--mixin": _mixin_completer,
    "--event-handlers": _event_handler_completer, "--build-type": _build_type_completer,
}


def install_completers(parser: argparse.ArgumentParser,
                       completer: Callable[..., list[str]] = _package_completer) -> None:
    """Give every argument that takes package names the package-name completer, and the
    options that take a value of a kind wsbuild knows their own."""
    stack = [parser]
    while stack:
        current = stack.pop()
        for action in current._actions:  # argparse has no public walk
            if isinstance(action, argparse._SubParsersAction):
                stack.extend(action.choices.values())
            elif _takes_packages(action):
                action.completer = completer  # type: ignore[attr-defined]
            elif action.metavar == "EXECUTABLE":
                action.completer = _executable_completer  # type: ignore[attr-defined]
            else:
                for option in action.option_strings:
                    if option in _VALUE_COMPLETERS:
                        action.completer = _VALUE_COMPLETERS[option]  # type: ignore[attr-defined]


def _complete_defines() -> None:
    """Answer for a `-D…` word after --cmake-args (or --ament-cmake-args) as argcomplete
    would (its output descriptor, its separator) and exit; return for anything else."""
    line = os.environ.get("COMP_LINE", "")[:int(os.environ.get("COMP_POINT", "0") or 0)]
    words = line.split(" ")
    current, before = words[-1], words[:-1]
    if not current.startswith("-D"):
        return
    opened = max((i for i, w in enumerate(before) if w in ("--cmake-args", "--ament-cmake-args")),
                 default=-1)
    if opened < 0 or "--" in before[opened:] or any(
            w.startswith("--") for w in before[opened + 1:]):
        return
    # bash splits words at `=`: it wants what comes after the last one
    cut = current.rfind("=") + 1 if "=" in os.environ.get("COMP_WORDBREAKS", "=") else 0
    found = [value[cut:] for value in _cmake_args_completer(current)]
    with os.fdopen(8, "w") as out:
        out.write(os.environ.get("_ARGCOMPLETE_IFS", "\013").join(found))
    os._exit(0)


def complete(parser: argparse.ArgumentParser) -> None:
    """Answer the shell's completion request (when _ARGCOMPLETE is set) and exit."""
    import argcomplete

    _complete_defines()  # `--cmake-args -D…`: argcomplete takes a `-` word for an option
    install_completers(parser)
    # an option's values first: the options only once a `-` is typed
    argcomplete.autocomplete(parser, always_complete_options=False)
    os._exit(0)  # not reached: autocomplete exits after answering
