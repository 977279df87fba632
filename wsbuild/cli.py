"""The command line: the argparse tree, the help formatter, and the only place that prints
errors and picks exit codes. Each verb's options, and their conversion into a request, belong
to its module under verbs/.

Exit codes: 0 success, 1 a package failed (build or test), 2 usage or workspace error,
130 interrupted (Ctrl-C; 143 SIGTERM, 129 SIGHUP), 3 an unexpected internal error (a bug in wsbuild).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
from collections.abc import Callable, Collection, Mapping, Sequence
from typing import TYPE_CHECKING, NoReturn
from pathlib import Path

from wsbuild import __version__, inputs
from wsbuild.errors import Interrupted, WsbuildError, environment_failure
from wsbuild.verbs import colcon, mixin
from wsbuild.verbs.arguments import PASSTHROUGH, add_negations, add_workspace_arguments
from wsbuild.verbs.arguments import collect_passthrough, may_pass_through
from wsbuild.verbs.colcon import apply_global_arguments, ignored_notes
from wsbuild.verbs.mixin import NOT_MIXED, apply_mixins
from wsbuild.words import did_you_mean

if TYPE_CHECKING:
    from wsbuild.engine.recording import ReplayRecorder


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """One screen per verb: each option's help on its own line, at most 100 columns, and the
    rarely used options (marked `secondary`) only in --help-all."""

    show_all = False

    def __init__(self, prog: str, indent_increment: int = 2, max_help_position: int = 36,
                 width: int | None = None) -> None:
        if width is None:
            width = min(shutil.get_terminal_size().columns, 100) - 2
        super().__init__(prog, indent_increment, max_help_position, width)

    def add_arguments(self, actions):  # type: ignore[no-untyped-def]
        if not self.show_all:
            actions = [a for a in actions if not getattr(a, "secondary", False)]
        super().add_arguments(actions)

    def _format_action(self, action: argparse.Action) -> str:
        # the verbs (or actions) one per line under their heading, without a line naming
        # their metavar above them
        if isinstance(action, argparse._SubParsersAction):
            return "".join(super(_Formatter, self)._format_action(choice)
                           for choice in action._get_subactions())
        return super()._format_action(action)


class _FullFormatter(_Formatter):
    show_all = True


class _HelpAll(argparse.Action):
    """--help-all: the help with every option."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):  # type: ignore[no-untyped-def]
        parser.formatter_class = _FullFormatter
        parser.print_help()
        if any(a.help == argparse.SUPPRESS and a.option_strings[0].startswith("--no-")
               for a in parser._actions if a.option_strings):
            print("\nEvery on/off option --X also has --no-X, which turns it off again (one a "
                  "defaults file or a mixin turned on).")
        parser.exit()


def _help_arguments(parser: argparse.ArgumentParser) -> None:
    """-h/--help and --help-all, named in the usage line rather than listed (one screen)."""
    parser.add_argument("-h", "--help", action="help", help=argparse.SUPPRESS)
    parser.add_argument("--help-all", action=_HelpAll, help=argparse.SUPPRESS)


#: every verb with what it does, in the order `wsbuild --help` lists them: the order of a day's
#: work (build and test, look at the workspace, then the rest), as colcon and cargo list theirs
VERBS: dict[str, str] = {
    "build": "Build the packages into install/",
    "test": "Run the packages' tests",
    "test-result": "Show the results of earlier test runs",
    "list": "List the packages of the workspace",
    "graph": "Show the dependency graph of the packages",
    "info": "Show a package's dependencies and where each is found",
    "run": "Run an executable of an installed package",
    "plan": "Split a build across the jobs of a CI matrix",
    "clean": "Remove what builds left in build/, install/ and log/",
    "deps": "Check or install the dependencies nothing provides",
    "report": "Show an earlier run's summary and its report page",
    "pkg": "Create a new package",
    "mixin": "Manage colcon-mixin's named option sets",
    "underlay": "Check or repair the ROS underlay in the virtualenv",
    "cache": "Look after the local build cache",
    "completion": "Print the shell code for Tab completion",
}

#: the end of `wsbuild --help` (and of a bare `wsbuild`)
_TOP_EPILOG = "Run `wsbuild VERB --help` for what a verb does and its options."


class _Parser(argparse.ArgumentParser):
    """argparse's parser, but a word that is no verb (or action) and an option the verb does
    not have get a "did you mean"."""

    def _check_value(self, action: argparse.Action, value: object) -> None:
        if isinstance(action, argparse._SubParsersAction) and action.choices is not None \
                and value not in action.choices:
            raise argparse.ArgumentError(None, unknown_choice_message(
                str(value), list(action.choices), str(action.metavar or "VERB").lower()))
        super()._check_value(action, value)

    def error(self, message: str) -> NoReturn:
        unknown = [word.split("=")[0] for word in message.split()
                   if word.startswith("--")] if message.startswith("unrecognized") else []
        options = [o for a in self._actions for o in a.option_strings]  # no public walk
        hint = did_you_mean(unknown[0], options) if unknown else ""
        super().error(f"{message} ({hint})" if hint else message)


def unknown_choice_message(word: str, choices: Sequence[str], kind: str) -> str:
    """`unknown verb 'biuld': did you mean 'build'?`, or the choices when none is close."""
    hint = did_you_mean(word, choices)
    return f"unknown {kind} '{word}': {hint}" if hint else \
        f"unknown {kind} '{word}'; the {kind}s: {', '.join(choices)}"


class _Tree:
    """The verbs' subparsers while build_parser() fills them."""

    def __init__(self, subparsers: argparse._SubParsersAction,  # type: ignore[type-arg]
                 pkg_arguments: bool, plugin_options: bool) -> None:
        self.subparsers = subparsers
        self.pkg_arguments = pkg_arguments
        self.plugin_options = plugin_options

    def verb(self, name: str, func: str, doc: str, *, selection: bool = True,
             operands: str = "") -> argparse.ArgumentParser:
        """A verb with the workspace (and `selection`) options; --help shows the common
        ones, --help-all every one."""
        sub = self.subparsers.add_parser(name, help=VERBS[name],
                                         description=doc.strip(), add_help=False,
                                         formatter_class=_Formatter,
                                         usage=f"%(prog)s [options]{operands}   "
                                               "(every option: --help-all)")
        sub.set_defaults(func=func)
        _help_arguments(sub)
        group = add_workspace_arguments(sub, selection=selection)
        if selection:  # the selections by earlier results and by cache, and colcon.meta
            from wsbuild.verbs import cache_selection, metas, results  # lazy: off `test-result`
            results.add_result_selection_arguments(group)
            cache_selection.add_cache_selection_arguments(group)
            metas.add_metadata_arguments(group)
        return sub


def build_parser(*, pkg_arguments: bool = True, verbs: Collection[str] | None = None,
                 plugin_options: bool = True) -> argparse.ArgumentParser:
    """The argument tree: every verb, or (`verbs`) only those named (a command line needs
    the verb it runs, and those its defaults files set options for; the other verbs'
    modules are not even imported). `pkg_arguments=False` leaves out `pkg create`'s
    options, whose defaults need the (slow to import) template machinery;
    `plugin_options=False` the options of third-party build types, whose scan costs."""
    inputs.declare_translations("messages")  # argparse's, through gettext
    parser = _Parser(
        prog="wsbuild",
        description="Build ROS 2 workspaces: fast, strict, and install-compatible with colcon.",
        epilog=_TOP_EPILOG,
        formatter_class=_Formatter,
        # argparse matches abbreviations of the options before the verb against the whole
        # command line: `clean --log` would be an ambiguous --log-base/--log-level
        allow_abbrev=False,
    )
    parser.add_argument("--version", action="version", version=f"wsbuild {__version__}")
    colcon.add_global_arguments(parser)
    # not required: a bare `wsbuild` prints the verbs (main()), not argparse's complaint
    subparsers = parser.add_subparsers(dest="verb", metavar="VERB", title="verbs")
    parser._action_groups.insert(0, parser._action_groups.pop())  # the verbs come first
    tree = _Tree(subparsers, pkg_arguments, plugin_options)
    for name in VERBS:
        if verbs is None or name in verbs:
            _ADDERS.get(name, _mirrored_parser)(tree, name)

    add_negations(parser)
    return parser



def verbs_named(argv: Sequence[str], also: Collection[str] = ()) -> set[str] | None:
    """The verbs a parser for `argv` needs: every word of it that names one, and `also`
    (verb keys such as "pkg.create" from defaults files); None (all of them) when `argv`
    names none, for the usage, --help or the error that lists them."""
    named = {item for item in argv if item in VERBS}
    if not named:
        return None
    return named | {key.split(".")[0] for key in also}


#: the verbs that mirror colcon's: their module under wsbuild.verbs, the function that runs
#: them, the name of their doc and of the function adding their own options, their operands;
#: colcon's options come from verbs/colcon.py's add_<verb>_arguments
_MIRRORED = {
    "list": ("listing", "run_list", "LIST_DOC", "add_list_arguments", ""),
    "graph": ("listing", "run_graph", "GRAPH_DOC", "add_graph_arguments", ""),
    "info": ("listing", "run_info", "INFO_DOC", "add_info_arguments", " [PKG ...]"),
    "build": ("build", "run_build_verb", "BUILD_DOC", "add_arguments", ""),
    "test": ("test", "run_test_verb", "TEST_DOC", "add_arguments", ""),
}


def _mirrored_parser(tree: _Tree, name: str) -> None:
    import importlib

    module_name, run, doc, own_arguments, operands = _MIRRORED[name]
    module = importlib.import_module(f"wsbuild.verbs.{module_name}")
    sub = tree.verb(name, f"wsbuild.verbs.{module_name}:{run}", getattr(module, doc),
                    operands=operands)
    getattr(module, own_arguments)(sub)
    type_arguments = getattr(module, "add_type_arguments", None)
    if type_arguments is not None:  # the build types' own options
        type_arguments(sub, plugins=tree.plugin_options)
    getattr(colcon, f"add_{name}_arguments")(sub)


def _clean_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs.clean import CLEAN_DOC, add_clean_arguments  # lazy: off the full no-op build

    add_clean_arguments(tree.verb(name, "wsbuild.verbs.clean:run_clean", CLEAN_DOC))


def _deps_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs import deps  # lazy: off the full no-op build and `list`

    deps.add_arguments(tree.verb(name, "wsbuild.verbs.deps:run_deps", deps.DEPS_DOC,
                                 operands=" [check|install]"))


def _completion_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs.completion import (
        COMPLETION_DOC, add_completion_arguments)  # lazy: off the full no-op build

    verbs = tree.subparsers
    sub = verbs.add_parser("completion", help=VERBS[name],
                           description=COMPLETION_DOC.strip(), formatter_class=_Formatter)
    sub.set_defaults(func="wsbuild.verbs.completion:run_completion")
    add_completion_arguments(sub)


def _test_result_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs import colcon, test  # lazy: off the full no-op build and `list`

    verbs = tree.subparsers
    sub = verbs.add_parser("test-result", help=VERBS[name],
                           description=test.TEST_RESULT_DOC.strip(), formatter_class=_Formatter,
                           add_help=False,
                           usage="%(prog)s [options]   (every option: --help-all)")
    _help_arguments(sub)
    sub.set_defaults(func="wsbuild.verbs.test:run_test_result_verb")
    test.add_result_arguments(sub)
    colcon.add_test_result_arguments(sub)


def _report_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs.run_report import (
        REPORT_DOC, add_report_arguments)  # lazy: off the full no-op build

    verbs = tree.subparsers
    sub = verbs.add_parser("report", help=VERBS[name],
                           description=REPORT_DOC.strip(), formatter_class=_Formatter)
    sub.set_defaults(func="wsbuild.verbs.run_report:run_report")
    add_report_arguments(sub)


def _run_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs import run  # lazy: off the full no-op build and `list`

    verbs = tree.subparsers
    sub = verbs.add_parser("run", help=VERBS[name],
                           description=run.RUN_DOC.strip(), formatter_class=_Formatter)
    sub.set_defaults(func="wsbuild.verbs.run:run_executable")
    run.add_arguments(sub)


def _mixin_parser(tree: _Tree, name: str) -> None:
    verbs = tree.subparsers
    sub = verbs.add_parser("mixin", help=VERBS[name],
                           description=mixin.MIXIN_DOC.strip(), formatter_class=_Formatter)
    actions = sub.add_subparsers(dest="action", metavar="ACTION")  # none: main() shows them

    def make(name: str, summary: str) -> argparse.ArgumentParser:
        # verbs/mixin.py words its summaries as phrases: listed, they start as the others do
        summary = summary[:1].upper() + summary[1:]
        return actions.add_parser(name, help=summary, description=summary,
                                  formatter_class=_Formatter)

    mixin.add_arguments(actions, make)


def _pkg_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs.pkg import CREATE_DOC  # lazy: off the full no-op build and `list`

    verbs = tree.subparsers
    sub = verbs.add_parser("pkg", help=VERBS[name],
                           description="Work with packages. Actions: create.",
                           formatter_class=_Formatter)
    actions = sub.add_subparsers(dest="action", metavar="ACTION")  # none: main() shows them
    create = actions.add_parser("create", help="Create a new package from templates",
                                description=CREATE_DOC.strip(), formatter_class=_Formatter)
    create.set_defaults(func="wsbuild.verbs.pkg:run_pkg_create")
    if tree.pkg_arguments:
        from wsbuild.verbs.pkg import add_pkg_create_arguments  # lazy: off the full no-op build

        add_pkg_create_arguments(create)


def _underlay_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs.underlay import (
        UNDERLAY_DOC, add_check_arguments)  # lazy: off the full no-op build

    verbs = tree.subparsers
    sub = verbs.add_parser("underlay", help=VERBS[name],
                           description=UNDERLAY_DOC.strip(), formatter_class=_Formatter)
    actions = sub.add_subparsers(dest="action", metavar="ACTION")  # none: main() shows them
    check = actions.add_parser("check", help="Report problems without changing anything")
    add_check_arguments(check)
    check.set_defaults(func="wsbuild.verbs.underlay:run_check")
    repair = actions.add_parser("repair", help="Fix the wheels' hard-coded paths in place")
    repair.set_defaults(func="wsbuild.verbs.underlay:run_repair")


def _cache_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs.cache import CACHE_DOC, add_prune_arguments  # lazy: off the full no-op build

    verbs = tree.subparsers
    sub = verbs.add_parser("cache", help=VERBS[name],
                           description=CACHE_DOC.strip(), formatter_class=_Formatter)
    actions = sub.add_subparsers(dest="action", metavar="ACTION")  # none: main() shows them
    stats = actions.add_parser("stats", help="Show the entries and the space they use")
    stats.set_defaults(func="wsbuild.verbs.cache:run_stats")
    prune = actions.add_parser("prune", help="Evict the least recently used entries")
    add_prune_arguments(prune)
    prune.set_defaults(func="wsbuild.verbs.cache:run_prune")
    verify = actions.add_parser("verify", help="Check every entry, remove bad ones")
    verify.set_defaults(func="wsbuild.verbs.cache:run_verify")


def _plan_parser(tree: _Tree, name: str) -> None:
    from wsbuild.verbs.plan import PLAN_DOC, add_arguments  # lazy: off the full no-op build

    add_arguments(tree.verb(name, "wsbuild.verbs.plan:run_plan_verb", PLAN_DOC))


#: the verbs that are not colcon's mirrored ones (_MIRRORED), by name
_ADDERS: dict[str, Callable[[_Tree, str], None]] = {
    "clean": _clean_parser, "deps": _deps_parser, "completion": _completion_parser,
    "test-result": _test_result_parser, "report": _report_parser, "run": _run_parser,
    "mixin": _mixin_parser, "pkg": _pkg_parser, "underlay": _underlay_parser,
    "cache": _cache_parser, "plan": _plan_parser,
}


def _known_long_options(argv: Sequence[str]) -> set[str]:
    """The long options of the verb `argv` runs and those before it (not the other verbs':
    `test --ctest-args --verbose` passes `--verbose` on, although test-result has one)."""
    from wsbuild.verbs.defaults import chosen_verb, verb_parsers  # lazy: off Tab completion

    parser = build_parser(pkg_arguments=False, verbs=verbs_named(argv), plugin_options=False)
    parsers = [parser, verb_parsers(parser).get(chosen_verb(parser, argv), parser)]
    names = {o for p in parsers for a in p._actions for o in a.option_strings  # no public walk
             if o.startswith("--")}
    return names - set(PASSTHROUGH)


def _resolve_func(spec: str):  # type: ignore[no-untyped-def]
    import importlib

    module, _, name = spec.partition(":")
    return getattr(importlib.import_module(module), name)


def parse_command_line(raw: list[str], environ: Mapping[str, str],
                       cwd: Path) -> argparse.Namespace:
    """`argv` → the arguments of the verb it runs: pass-through values collected, defaults
    files applied (colcon-defaults' ~/.colcon/defaults.yaml, then <ws>/wsbuild.yaml), then the
    mixins it names. Usage errors exit (2); bad files raise WsbuildError."""
    from wsbuild.verbs.defaults import parse_with_defaults  # lazy: off Tab completion

    if any(may_pass_through(item) for item in raw):
        raw = collect_passthrough(raw, _known_long_options(raw))

    def make_parser(verbs_in_defaults: set[str], plugin_options: bool = False
                    ) -> argparse.ArgumentParser:
        full = "pkg" in raw or any(v.split(".")[0] == "pkg" for v in verbs_in_defaults)
        return build_parser(pkg_arguments=full, verbs=verbs_named(raw, verbs_in_defaults),
                            plugin_options=plugin_options)

    def finish(parser: argparse.ArgumentParser, verb: str, args: argparse.Namespace) -> None:
        _finish(parser, verb, args, environ, cwd)

    return parse_with_defaults(
        raw, environ, cwd, make_parser, finish=finish,
        make_full_parser=lambda verbs: make_parser(verbs, plugin_options=True))


def main(argv: Sequence[str] | None = None, *, recorder: ReplayRecorder | None = None) -> int:
    """Run one command line. `recorder`: the one launch.py made for a verb that can be
    replayed; it reaches the verb with the run's terminal (`args.terminal`)."""
    raw = list(sys.argv[1:] if argv is None else argv)
    if "_ARGCOMPLETE" in os.environ:  # the shell asks for completions (wsbuild completion)
        from wsbuild.verbs.completion import complete  # lazy: off the full no-op build and `list`

        complete(build_parser(pkg_arguments="pkg" in os.environ.get("COMP_LINE", "")))
    try:
        args = parse_command_line(raw, os.environ, Path.cwd())
    except WsbuildError as exc:
        print(f"wsbuild: error: {exc}", file=sys.stderr)
        return exc.exit_code
    if not hasattr(args, "func"):  # a bare `wsbuild` or `wsbuild cache`: what each one does
        _print_choices(args.verb)
        return 2
    from wsbuild.engine.process import (
        interrupted_exit_code, stop_signals_interrupt)  # lazy: off Tab completion
    from wsbuild.redaction import remember_environment  # lazy: off Tab completion and `--help`
    from wsbuild.reporter import Terminal  # lazy: off `build --help` and `pkg create --help`

    # the values of the environment's secrets are hidden in all wsbuild writes
    remember_environment(os.environ)

    # where the verb's words go (through the recorder's copies when it is recorded)
    args.terminal = terminal = Terminal.of(recorder)
    terminal.notes(ignored_notes(args, args.verb))
    try:
        with stop_signals_interrupt():
            return int(_resolve_func(args.func)(args) or 0)
    except WsbuildError as exc:
        print(f"wsbuild: error: {exc}", file=sys.stderr)
        return interrupted_exit_code() if isinstance(exc, Interrupted) else exc.exit_code
    except KeyboardInterrupt:
        print("wsbuild: interrupted", file=sys.stderr)
        return interrupted_exit_code()
    except BrokenPipeError:
        # `wsbuild list | head`: the reader went away; not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:
        # a full disk or a read-only directory is the machine's failure, not a bug
        message = environment_failure(exc, doing=f"running wsbuild {args.verb}")
        if message is None:
            return _internal_error()
        print(f"wsbuild: error: {message}", file=sys.stderr)
        return 1
    except Exception:
        return _internal_error()


def _print_choices(verb: str | None) -> None:
    """The help of the top level (every verb) or of a verb with actions (every action)."""
    parser = build_parser(pkg_arguments=False, verbs=None if verb is None else {verb})
    if verb is not None:
        from wsbuild.verbs.defaults import verb_parsers  # lazy: off Tab completion

        parser = verb_parsers(parser)[verb]
    parser.print_help()


def _finish(parser: argparse.ArgumentParser, verb: str, args: argparse.Namespace,
            environ: Mapping[str, str], cwd: Path) -> None:
    """After parsing: the mixins the command line names, and colcon's options before the verb."""
    if verb and verb.split(".")[0] not in NOT_MIXED:
        apply_mixins(parser, verb, args, environ, cwd)
    apply_global_arguments(args)


def _internal_error() -> int:
    """An unexpected exception: its traceback, and the word that it is a bug (exit 3)."""
    import traceback

    traceback.print_exc()
    print("wsbuild: internal error: this is a bug in wsbuild; please report it with the "
          "traceback above", file=sys.stderr)
    return 3
