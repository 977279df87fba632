"""colcon's command lines run unchanged: every option of colcon's own parsers is accepted,
command lines as real projects write them parse, and colcon (`colcon list -n`) is the oracle
for package selection."""

from __future__ import annotations

import argparse
import json
import shlex
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

from conftest import run_wsbuild
from wsbuild.build_types.cmake_options import CMAKE_ARGS
from wsbuild.cli import build_parser, parse_command_line
from wsbuild.verbs.build import request_from_args

HERE = Path(__file__).resolve().parent
MIXIN_INDEX = HERE / "data" / "mixin_index"
#: the verbs of colcon whose every option wsbuild accepts ("" : the options before the verb)
COLCON_VERBS = ("", "build", "test", "test-result", "list", "graph", "info")


def verb_parser(verb: str) -> argparse.ArgumentParser:
    parser = build_parser()
    if not verb:
        return parser
    verbs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return verbs.choices[verb]


@pytest.fixture(scope="module")
def colcon_parsers(colcon: Path) -> dict[str, list[dict[str, object]]]:
    """colcon's own parsers, from the installed colcon packages (tests/colcon_parsers.py)."""
    done = subprocess.run([str(colcon.parent / "python"), str(HERE / "colcon_parsers.py")],
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize("verb", COLCON_VERBS, ids=lambda v: v or "global")
def test_every_colcon_option_is_accepted(colcon_parsers: dict[str, list[dict[str, object]]],
                                         verb: str) -> None:
    ours = verb_parser(verb)._option_string_actions
    missing = [option for action in colcon_parsers[verb] for option in action["options"]
               if option not in ours]  # type: ignore[union-attr]
    assert not missing, f"wsbuild {verb} lacks colcon's {missing}"


@pytest.mark.parametrize("verb", ("build", "test"))
def test_every_choice_of_colcon_is_accepted(colcon_parsers: dict[str, list[dict[str, object]]],
                                            verb: str) -> None:
    parser = build_parser()
    for action in colcon_parsers[verb]:
        for choice in action["choices"] or ():  # type: ignore[union-attr]
            option = action["options"][0]  # type: ignore[index]
            parser.parse_args([verb, option, str(choice)])  # a usage error exits


def test_the_colcon_parsers_are_really_enumerated(
        colcon_parsers: dict[str, list[dict[str, object]]]) -> None:
    """The oracle itself: a few options each plugin adds are there (colcon-cmake, -ros,
    -package-selection, -mixin, -metadata, -parallel-executor, -test-result)."""
    options = {verb: {o for a in actions for o in a["options"]}  # type: ignore[attr-defined]
               for verb, actions in colcon_parsers.items()}
    assert {"--cmake-args", "--ament-cmake-args", "--packages-select-build-failed", "--mixin",
            "--metas", "--parallel-workers", "--event-handlers"} <= options["build"]
    assert {"--delete-yes", "--result-files-only"} <= options["test-result"]
    assert {"--log-base", "--log-level"} <= options[""]


#: command lines as READMEs, Dockerfiles, CI workflows and the ROS 2 tutorials write them
COMMAND_LINES = """
colcon build
colcon build --symlink-install
colcon build --merge-install
colcon build --symlink-install --event-handlers console_direct+
colcon build --event-handlers console_cohesion+ --packages-up-to demo_nodes_py
colcon build --event-handlers console_direct+ console_stderr- --cmake-args -DCMAKE_BUILD_TYPE=Release
colcon build --cmake-args -DCMAKE_BUILD_TYPE=RelWithDebInfo -DBUILD_TESTING=OFF
colcon build --cmake-args --no-warn-unused-cli -G Ninja
colcon build --cmake-args ' -DCMAKE_BUILD_TYPE=Release'
colcon build --cmake-args=-DCMAKE_BUILD_TYPE=Debug
colcon build --mixin release
colcon build --mixin release ccache compile-commands
colcon build --mixin rel-with-deb-info ninja --symlink-install
colcon build --mixin debug coverage-gcc --packages-select demo_cpp_lib
colcon --log-base /dev/null build --event-handlers console_direct+
colcon --log-level info build --packages-select demo_tools
colcon --log-base build_logs build --merge-install
colcon build --parallel-workers 2 --executor parallel
colcon build --executor sequential --event-handlers console_cohesion+ summary-
colcon build --packages-select-build-failed
colcon build --packages-skip-build-finished --continue-on-error
colcon build --packages-above demo_cpp_lib --allow-overriding demo_cpp_lib
colcon build --packages-skip demo_nodes_py --packages-ignore demo_description
colcon build --packages-select-regex 'demo_.*' --packages-skip-regex '.*_py'
colcon build --packages-up-to-regex 'demo_cpp_.*'
colcon build --packages-above-and-dependencies demo_interfaces
colcon build --packages-above-depth 1 demo_cpp_lib
colcon build --packages-select-by-dep demo_tools
colcon build --packages-skip-by-dep std_msgs
colcon build --packages-skip-up-to demo_interfaces
colcon build --packages-start demo_cpp_lib --packages-end demo_cpp_app
colcon build --base-paths src --build-base build --install-base install
colcon build --paths src/demo_tools
colcon build --ament-cmake-args -DCMAKE_BUILD_TYPE=Release
colcon build --catkin-skip-building-tests --catkin-cmake-args -DCATKIN_ENABLE_TESTING=0
colcon build --cmake-target install --cmake-target-skip-unavailable
colcon build --cmake-clean-cache --cmake-clean-first --cmake-force-configure
colcon build --metas ./colcon.meta --ignore-user-meta
colcon build --test-result-base test_results
colcon build --event-handler console_direct+
colcon build --event-handlers log- store_result- desktop_notification- terminal_title- status-
colcon build --event-handlers console_package_list+ console_start_end- compile_commands+
colcon build --mixin-files extra.mixin --mixin extra
colcon build --symlink-install --packages-up-to demo_nodes_py --cmake-args -DCMAKE_EXPORT_COMPILE_COMMANDS=ON --event-handlers console_direct+
colcon build --cmake-arg -DCMAKE_BUILD_TYPE=Release -- --symlink-install
colcon test
colcon test --event-handlers console_direct+
colcon test --packages-select demo_nodes_py --pytest-args -m "not xfail"
colcon test --ctest-args --output-on-failure
colcon test --ctest-args -R gtest -j4 --
colcon test --pytest-args -k 'not slow' -- --retest-until-pass 2
colcon test --return-code-on-test-failure
colcon test --retest-until-fail 3 --abort-on-error
colcon test --packages-select-test-failures
colcon test --packages-skip-test-passed
colcon test --merge-install --test-result-base test_results
colcon test --pytest-with-coverage --python-testing pytest
colcon test --python-testing setuppy_test --unittest-args -v
colcon test --mixin coverage-pytest
colcon test --executor sequential --parallel-workers 1 --event-handlers console_cohesion+
colcon test-result --all
colcon test-result --verbose
colcon test-result --test-result-base build --all --result-files-only
colcon test-result --delete-yes
colcon list
colcon list -n
colcon list -p -t
colcon list -g
colcon list --topological-graph-dot --topological-graph-legend
colcon list --names-only --packages-up-to demo_nodes_py
colcon list -n --packages-select-build-failed
colcon graph --dot
colcon graph --density --legend
colcon graph --dot --dot-cluster --dot-include-skipped
colcon info
colcon info demo_nodes_py
colcon info --packages-select demo_tools
colcon --log-level debug list -n
""".strip().splitlines()


@pytest.fixture
def colcon_home(tmp_path: Path) -> Path:
    """A COLCON_HOME whose mixins are the fixture repository's (as `colcon mixin update` left
    them), and a working directory with an extra mixin file."""
    home = tmp_path / "colcon_home"
    shutil.copytree(MIXIN_INDEX, home / "mixin" / "default",
                    ignore=shutil.ignore_patterns("index.yaml", "README.md"))
    (tmp_path / "extra.mixin").write_text('{"build": {"extra": {"parallel-workers": 3}}}\n')
    return home


def parse(line: str, home: Path, cwd: Path) -> argparse.Namespace:
    argv = shlex.split(line)
    assert argv[0] == "colcon"
    try:
        return parse_command_line(argv[1:], {"COLCON_HOME": str(home), "HOME": str(cwd)}, cwd)
    except SystemExit as exc:
        raise AssertionError(f"refused ({exc.code}): {line}") from None


def test_there_are_enough_command_lines() -> None:
    assert len(COMMAND_LINES) >= 60


@pytest.mark.parametrize("line", COMMAND_LINES)
def test_colcon_command_lines_are_accepted(line: str, colcon_home: Path) -> None:
    parse(line, colcon_home, colcon_home.parent)


def test_the_values_arrive_as_colcon_passes_them(colcon_home: Path) -> None:
    cwd = colcon_home.parent

    def cmake_args(line: str) -> tuple[str, ...]:
        build = request_from_args(parse(line, colcon_home, cwd)).build
        return build.value(CMAKE_ARGS)  # type: ignore[return-value]

    assert cmake_args("colcon build --cmake-args --no-warn-unused-cli -G Ninja") == (
        "--no-warn-unused-cli", "-G", "Ninja")
    assert cmake_args("colcon build --cmake-args ' -DCMAKE_BUILD_TYPE=Release'") == (
        "-DCMAKE_BUILD_TYPE=Release",)
    assert cmake_args("colcon build --cmake-arg -DA=1 -- --symlink-install") == ("-DA=1",)
    # a mixin's list comes before the command line's; mixins apply in the order named
    assert cmake_args("colcon build --mixin release ccache --cmake-args -DX=1") == (
        "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_C_COMPILER_LAUNCHER=ccache",
        "-DCMAKE_CXX_COMPILER_LAUNCHER=ccache", "-DX=1")
    # any other option: the command line wins over the mixin
    assert parse("colcon build --mixin extra --mixin-files extra.mixin", colcon_home,
                 cwd).parallel_workers == 3
    assert parse("colcon build --mixin-files extra.mixin --mixin extra --parallel-workers 5",
                 colcon_home, cwd).parallel_workers == 5
    test = parse("colcon test --pytest-args -m 'not xfail' --ctest-args --output-on-failure",
                 colcon_home, cwd)
    assert (test.pytest_args, test.ctest_args) == (["-m", "not xfail"], ["--output-on-failure"])
    assert parse("colcon build --event-handler console_direct+", colcon_home,
                 cwd).event_handlers == ["console_direct+"]
    assert parse("colcon --log-base elsewhere build", colcon_home, cwd).log_base == "elsewhere"
    assert parse("colcon --log-base elsewhere build --log-base mine", colcon_home,
                 cwd).log_base == "mine"


def test_an_unknown_event_handler_is_a_usage_error_naming_the_known(tmp_path: Path) -> None:
    result = run_wsbuild("build", "--event-handlers", "console_drect+", cwd=tmp_path)
    assert result.returncode == 2
    assert "console_drect+" in result.stderr and "console_direct" in result.stderr
    assert "usage: wsbuild build" in result.stderr


def test_an_unknown_option_shows_the_verbs_usage(tmp_path: Path) -> None:
    result = run_wsbuild("build", "--no-such-option", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.startswith("usage: wsbuild build")


def test_an_option_without_meaning_is_accepted_with_one_line_saying_why(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pa": ("ament_python", [])})
    result = run_wsbuild("--log-level", "debug", "list", "-n", "--topological-graph-legend",
                         cwd=ws)
    assert result.returncode == 0, result.stderr
    notes = result.stderr.splitlines()
    assert notes == [
        "wsbuild: note: --log-level is ignored: wsbuild keeps no log of its own; each "
        "package's log in log/ is complete",
        "wsbuild: note: --topological-graph-legend is ignored: wsbuild's graph draws no legend"]


# ------------------------------------------------------------------- colcon as the oracle

ORACLE_SPEC = {"a": ("cmake", []), "b": ("cmake", ["a"]), "c": ("cmake", ["b"]),
               "d": ("cmake", ["a"]), "e": ("cmake", []), "f": ("cmake", ["c", "e"]),
               "g_x": ("cmake", ["d"])}

SELECTIONS = [
    "", "-t", "--packages-select b d", "--packages-skip b d", "--packages-up-to c",
    "--packages-up-to c -t", "--packages-above b", "--packages-above b -t",
    "--packages-above-and-dependencies d", "--packages-above-depth 1 a",
    "--packages-skip-up-to b", "--packages-select-regex '^[ab]'", "--packages-skip-regex '^g'",
    "--packages-up-to-regex 'c|e'", "--packages-ignore e", "--packages-ignore-regex 'd.*'",
    "--packages-start b --packages-end f -t", "--packages-select-by-dep a",
    "--packages-skip-by-dep b", "--packages-up-to f --packages-skip c",
]


@pytest.mark.slow
def test_colcon_and_wsbuild_list_the_same_packages(colcon: Path,
                                                   make_workspace: Callable[..., Path],
                                                   tmp_path: Path) -> None:
    ws = make_workspace(ORACLE_SPEC)
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "COLCON_HOME": str(tmp_path / "ch"),
           "LC_ALL": "C.UTF-8"}
    for selection in SELECTIONS:
        args = ["list", "-n", *shlex.split(selection)]
        theirs = subprocess.run([str(colcon), *args], cwd=ws, env=env, capture_output=True,
                                text=True, timeout=120, check=False)
        assert theirs.returncode == 0, theirs.stderr
        ours = run_wsbuild(*args, cwd=ws)
        assert ours.returncode == 0, ours.stderr
        assert ours.stdout.split() == theirs.stdout.split(), selection


def test_defaults_files_apply_behind_options_before_the_verb(colcon_home: Path) -> None:
    cwd = colcon_home.parent
    (cwd / "wsbuild.yaml").write_text("build:\n  parallel-workers: 3\n")
    args = parse("colcon --log-base elsewhere --log-level info build", colcon_home, cwd)
    assert (args.parallel_workers, args.log_base) == (3, "elsewhere")


def test_pass_through_values_end_only_at_the_verbs_own_options(colcon_home: Path) -> None:
    """`--verbose` is test-result's option, not test's: ctest gets it."""
    args = parse("colcon test --ctest-args --verbose --timeout 60 --abort-on-error", colcon_home,
                 colcon_home.parent)
    assert (args.ctest_args, args.abort_on_error) == (["--verbose", "--timeout", "60"], True)
