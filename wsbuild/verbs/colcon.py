"""colcon's options beyond wsbuild's own, so that colcon's command lines run unchanged: their
declarations (left to --help-all), colcon's event handlers mapped onto the reporter, and the
options accepted without effect, each with the one line that says why."""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from typing import TYPE_CHECKING

from wsbuild.verbs.arguments import secondary
from wsbuild.verbs.mixin import add_mixin_arguments
from wsbuild.workspace.root import BUILD_BASE, LOG_BASE

if TYPE_CHECKING:
    from wsbuild.reporter import Console

#: colcon's event handlers (colcon-core, -output, -notification, -cmake, -package-selection,
#: -parallel-executor) → what wsbuild does about them (the reason in a note, for the others)
EVENT_HANDLERS: dict[str, str] = {
    "compile_commands": "build/compile_commands.json is always merged",
    "console_cohesion": "each package's output in one block when it finishes",
    "console_direct": "every step's output as it happens",
    "console_package_list": "the packages to process, in order, before the run",
    "console_start_end": "the Starting >>> / Finished <<< lines",
    "console_stderr": "each package's warnings (stderr) when it finishes",
    "desktop_notification": "no desktop notifications",
    "event_log": "log/ keeps each package's command and output logs",
    "log": "log/ is always written",
    "log_command": "command.log always lists every command",
    "parallel_status": "the live status line (terminal only)",
    "status": "the live status line (terminal only)",
    "store_result": "build/<pkg>/.wsbuild/ always records each result",
    "summary": "the summary at the end",
    "terminal_title": "no terminal title",
}

#: what wsbuild always does: `NAME+` asks for nothing new, `NAME-` is ignored with a note
ALWAYS_ON = ("compile_commands", "event_log", "log", "log_command", "store_result")
#: what wsbuild never does: `NAME-` asks for nothing new, `NAME+` is ignored with a note
NEVER = ("desktop_notification", "terminal_title")


def event_handler_switch(value: str) -> str:
    """argparse type of --event-handlers: `NAME+` or `NAME-` with a name colcon knows."""
    name, sign = value[:-1], value[-1:]
    if sign not in ("+", "-") or name not in EVENT_HANDLERS:
        known = ", ".join(sorted(EVENT_HANDLERS))
        raise argparse.ArgumentTypeError(
            f"'{value}' is not NAME+ or NAME- with a known event handler; known: {known}")
    return value


def console_from_args(args: argparse.Namespace) -> Console:
    """What the reporter shows, from `--event-handlers a+ b- …` (later ones win)."""
    from wsbuild.reporter import Console  # lazy: off `build --help` and `pkg create --help`

    switches = {value[:-1]: value.endswith("+") for value in getattr(args, "event_handlers",
                                                                      None) or ()}
    return Console(
        direct=switches.get("console_direct", False),
        cohesion=switches.get("console_cohesion", False),
        package_list=switches.get("console_package_list", False),
        start_end=switches.get("console_start_end", True),
        stderr=switches.get("console_stderr", True),
        summary=switches.get("summary", True),
        status=switches.get("status", switches.get("parallel_status")),
    )


def add_event_handler_argument(parser: argparse._ActionsContainer) -> None:
    secondary(parser.add_argument(
        "--event-handlers", nargs="*", type=event_handler_switch, metavar="NAME+|NAME-",
        help="colcon's event handlers, e.g. console_direct+ (live output), console_cohesion+ "
             "(output per package), summary-, status-"))


def add_results_base_argument(parser: argparse._ActionsContainer) -> None:
    """--build-base for the verbs that only read it (the result-based selections)."""
    secondary(parser.add_argument(
        "--build-base", default=BUILD_BASE, metavar="DIR",
        help=f"where the previous results are, for --packages-*-build-*/-test-* "
             f"(default: {BUILD_BASE})"))


def add_global_arguments(parser: argparse.ArgumentParser) -> None:
    """The options colcon takes before the verb."""
    parser.add_argument("--log-base", dest="global_log_base", metavar="DIR",
                        help="log directory of the verb (colcon's place for it; default: log)")
    parser.add_argument("--log-level", metavar="LEVEL",
                        help="accepted for colcon compatibility (wsbuild keeps no log of its own)")


def apply_global_arguments(args: argparse.Namespace) -> None:
    """While parsing: colcon's `--log-base` given before the verb becomes the verb's (the
    verb's own --log-base wins)."""
    given = getattr(args, "global_log_base", None)
    if given and getattr(args, "log_base", LOG_BASE) == LOG_BASE:
        args.log_base = given


def add_build_arguments(parser: argparse.ArgumentParser) -> None:
    """colcon build's options that wsbuild's own list lacks."""
    group = parser.add_argument_group("colcon's build options (--help-all only)")
    add_event_handler_argument(group)
    add_mixin_arguments(group)
    secondary(group.add_argument("--catkin-cmake-args", action="append", metavar="ARG",
                                 help="CMake arguments for catkin packages (ROS 1)"))
    secondary(group.add_argument("--catkin-skip-building-tests", action="store_true",
                                 help="catkin packages: no test targets"))
    secondary(group.add_argument("--cmake-target-skip-unavailable", action="store_true",
                                 help="skip packages without --cmake-target"))
    secondary(group.add_argument("--test-result-base", metavar="DIR",
                                 help="where ament_cmake tests will write their results"))


def add_test_arguments(parser: argparse.ArgumentParser) -> None:
    """colcon test's options that wsbuild's own list lacks."""
    group = parser.add_argument_group("colcon's test options (--help-all only)")
    add_event_handler_argument(group)
    add_mixin_arguments(group)
    secondary(group.add_argument("--pytest-with-coverage", action="store_true",
                                 help="pytest with coverage (pytest-cov)"))
    secondary(group.add_argument("--python-testing", choices=("pytest", "setuppy_test"),
                                 help="the Python test runner (wsbuild: pytest)"))
    secondary(group.add_argument("--unittest-args", action="append", metavar="ARG",
                                 help="arguments for unittest"))


def add_list_arguments(parser: argparse.ArgumentParser) -> None:
    """colcon list's graph options."""
    group = parser.add_argument_group("colcon's list options (--help-all only)")
    secondary(group.add_argument("-g", "--topological-graph", action="store_true",
                                 help="the dependency graph (as `wsbuild graph`)"))
    secondary(group.add_argument("--topological-graph-dot", action="store_true",
                                 help="the dependency graph in Graphviz dot"))
    for option in ("--topological-graph-density", "--topological-graph-legend",
                   "--topological-graph-dot-cluster", "--topological-graph-dot-include-skipped"):
        secondary(group.add_argument(option, action="store_true",
                                     help="accepted for colcon compatibility"))
    add_results_base_argument(group)
    add_mixin_arguments(group)


def add_graph_arguments(parser: argparse.ArgumentParser) -> None:
    """colcon graph's options wsbuild's own list lacks."""
    group = parser.add_argument_group("colcon's graph options (--help-all only)")
    for option in ("--density", "--legend", "--dot-cluster", "--dot-include-skipped"):
        secondary(group.add_argument(option, action="store_true",
                                     help="accepted for colcon compatibility"))
    add_results_base_argument(group)
    add_mixin_arguments(group)


def add_info_arguments(parser: argparse.ArgumentParser) -> None:
    """colcon info's options wsbuild's own list lacks."""
    group = parser.add_argument_group("colcon's info options (--help-all only)")
    add_results_base_argument(group)
    add_mixin_arguments(group)


def add_test_result_arguments(parser: argparse.ArgumentParser) -> None:
    """colcon test-result's options wsbuild's own list lacks."""
    group = parser.add_argument_group("colcon's test-result options (--help-all only)")
    secondary(group.add_argument("--delete", action="store_true",
                                 help="delete the result files (asks first)"))
    secondary(group.add_argument("--delete-yes", action="store_true",
                                 help="delete the result files without asking"))
    add_mixin_arguments(group)


#: dest → why wsbuild accepts the option without acting on it (said once when given)
IGNORED: dict[str, str] = {
    "log_level": "wsbuild keeps no log of its own; each package's log in log/ is complete",
    "catkin_cmake_args": "wsbuild builds no catkin (ROS 1) packages",
    "catkin_skip_building_tests": "wsbuild builds no catkin (ROS 1) packages",
    "cmake_target_skip_unavailable": "every CMake package builds --cmake-target; one without "
                                     "it fails with CMake's message",
    "test_result_base": "on `build` it only tells ament_cmake where tests will write; "
                        "use `wsbuild test --test-result-base`",
    "pytest_with_coverage": "pass pytest-cov's options yourself: --pytest-args --cov=PKG",
    "unittest_args": "wsbuild runs Python tests with pytest, which also runs unittest tests; "
                     "use --pytest-args",
    "topological_graph_density": "wsbuild's graph has no density figure",
    "topological_graph_legend": "wsbuild's graph draws no legend",
    "topological_graph_dot_cluster": "wsbuild's dot output has no clusters",
    "topological_graph_dot_include_skipped": "wsbuild's graph shows the selected packages only",
    "density": "wsbuild's graph has no density figure",
    "legend": "wsbuild's graph draws no legend",
    "dot_cluster": "wsbuild's dot output has no clusters",
    "dot_include_skipped": "wsbuild's graph shows the selected packages only",
}

#: --python-testing values with no meaning for wsbuild
_PYTHON_TESTING_IGNORED = "setuppy_test"


def ignored_notes(args: argparse.Namespace, verb: str) -> list[str]:
    """One line for each given option that has no effect in wsbuild, saying why."""
    notes: list[str] = []
    for dest, why in IGNORED.items():
        if dest == "test_result_base" and verb != "build":
            continue
        value = getattr(args, dest, None)
        if value not in (None, False, [], ()):
            notes.append(f"--{dest.replace('_', '-')} is ignored: {why}")
    if getattr(args, "python_testing", None) == _PYTHON_TESTING_IGNORED:
        notes.append("--python-testing setuppy_test is ignored: wsbuild runs Python tests "
                     "with pytest (setup.py test is gone from setuptools)")
    notes += _event_handler_notes(getattr(args, "event_handlers", None) or ())
    return notes


def _event_handler_notes(values: Iterable[str]) -> list[str]:
    notes = []
    for value in dict.fromkeys(values):
        name, on = value[:-1], value.endswith("+")
        if (name in ALWAYS_ON and not on) or (name in NEVER and on):
            notes.append(f"--event-handlers {value} is ignored: {EVENT_HANDLERS[name]}")
    return notes
