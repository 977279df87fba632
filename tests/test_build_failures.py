"""`wsbuild build` when things go wrong: broken packages, missing dependencies, bad input."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

from test_build_helpers import (
    build,
    clean_env,
    output,
    requires_ros,
    snapshot,
    write,
    write_ament_python,
    write_cmake,
    wsbuild,
)

DATA_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
install(FILES data.txt DESTINATION share/${{PROJECT_NAME}})
"""

VICTIM_MAIN = "def main():\n    print('victim v1')\n"


def _reproduce(result: subprocess.CompletedProcess[str], ws: Path) -> tuple[str, str]:
    """The reproduce line the screen shows (run it from the workspace) and the text of the
    script it names."""
    lines = result.stdout.splitlines()
    line = lines[lines.index("  reproduce by hand:") + 1].strip()
    script = ws / line.split()[0]
    return line, script.read_text()


def _data_package(src: Path, name: str, deps: list[str] | None = None) -> Path:
    return write_cmake(src, name, DATA_CMAKE.format(name=name), depend=deps or [],
                       files={"data.txt": f"{name} v1\n"})


def _break(pkg: Path, kind: str) -> str:
    """Break a package that built before; return a text its failure output must show."""
    if kind == "cmake-syntax":
        with open(pkg / "CMakeLists.txt", "a") as handle:
            handle.write("install(FILES data.txt\n")  # unbalanced parenthesis
        return "Parse error"
    setup = pkg / "setup.py"
    setup.write_text("raise RuntimeError('broken on purpose')\n" + setup.read_text())
    return "RuntimeError: broken on purpose"


def _victim(src: Path, kind: str) -> Path:
    if kind == "cmake-syntax":
        return _data_package(src, "victim")
    return write_ament_python(src, "victim", modules={"main.py": VICTIM_MAIN},
                              data={"config/params.yaml": "rate: 1\n"},
                              scripts={"victim_main": "victim.main:main"})


@pytest.mark.parametrize("layout", ["isolated", "merged"])
@pytest.mark.parametrize("kind", ["cmake-syntax", "setup-py-raises"])
def test_broken_package_fails_and_keeps_its_previous_install(tmp_path: Path, kind: str,
                                                             layout: str) -> None:
    ws = tmp_path / "ws"
    src = ws / "src"
    pkg = _victim(src, kind)
    _data_package(src, "zz_other")
    merged = ["--merge-install"] if layout == "merged" else []
    build(ws, *merged)
    install = ws / "install"
    victim_files = _package_files(ws, "victim", merged=bool(merged))
    assert victim_files
    victim_before = _file_states(install, victim_files)
    shown = _break(pkg, kind)

    # by default: the unrelated package, up to date or not started, is left alone
    other_before = snapshot(install if merged else install / "zz_other")
    result = wsbuild("build", *merged, cwd=ws)
    assert result.returncode == 1, output(result)
    if not merged:
        assert snapshot(install / "zz_other") == other_before

    # with --continue-on-error an unrelated package that changed builds next to the failure
    write(src / "zz_other" / "data.txt", "zz_other v2\n")
    result = wsbuild("build", "--continue-on-error", *merged, cwd=ws)

    assert result.returncode == 1, output(result)
    lines = result.stdout.splitlines()
    failed = [line for line in lines if line.startswith("Failed")]
    assert len(failed) == 1 and "victim" in failed[0], output(result)
    assert shown in result.stdout
    log_line = next(line for line in lines if line.strip().startswith("log:"))
    log_dir = Path(log_line.split("log:", 1)[1].strip())
    assert log_dir.name == "victim"
    assert shown in (log_dir / "stdout_stderr.log").read_text()
    assert (log_dir / "command.log").is_file()
    reproduce, script = _reproduce(result, ws)
    # a short line on the screen: a script that sets the step's environment (the whole line,
    # with its dozen library directories, is in command.log)
    assert reproduce.startswith("build/victim/reproduce.sh") and len(reproduce) < 100
    assert script.startswith("#!/bin/sh\n") and "\ncd " in script and "\nexport PATH=" in script
    assert "victim" in result.stderr and "failed" in result.stderr
    # the previous install of the broken package is intact and still works
    assert _file_states(install, victim_files) == victim_before
    prefix = install if merged else install / "victim"
    if kind == "cmake-syntax":
        assert (prefix / "share" / "victim" / "data.txt").read_text() == "victim v1\n"
    else:
        run = wsbuild("run", "victim", "victim_main", cwd=ws)
        assert run.returncode == 0 and run.stdout.strip() == "victim v1", output(run)
    other = install if merged else install / "zz_other"
    assert (other / "share" / "zz_other" / "data.txt").read_text() == "zz_other v2\n"


def _package_files(ws: Path, name: str, *, merged: bool) -> list[str]:
    """Paths (below install/) of the files `name` installed."""
    prefix = ws / "install"
    root = prefix if merged else prefix / name
    return sorted(str(Path(dirpath, f).relative_to(prefix))
                  for dirpath, _, files in os.walk(root) for f in files
                  if not merged or name in Path(dirpath, f).relative_to(prefix).parts)


def _file_states(prefix: Path, files: list[str]) -> dict[str, tuple[bytes, int]]:
    return {rel: ((prefix / rel).read_bytes(), (prefix / rel).stat().st_mtime_ns)
            for rel in files}


def test_reproduce_command_reproduces_the_failure(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    pkg = _data_package(ws / "src", "victim")
    _break(pkg, "cmake-syntax")
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 1, output(result)
    reproduce, _ = _reproduce(result, ws)
    again = subprocess.run(["bash", "-c", reproduce], cwd=ws, capture_output=True, text=True,
                           timeout=60)
    assert again.returncode != 0
    assert "Parse error" in again.stdout + again.stderr


GREETER_CONFIG = """\
cmake_minimum_required(VERSION 3.14)
project(greeter NONE)
file(WRITE ${CMAKE_BINARY_DIR}/greeterConfig.cmake "set(greeter_GREETING \\"from greeter\\")\\n")
install(FILES ${CMAKE_BINARY_DIR}/greeterConfig.cmake DESTINATION share/greeter/cmake)
"""
#: configure needs greeter (found through the dependency environment); `step` says where it
#: then fails: in configure, or compiling (under the compiler cache and the jobserver)
BROKEN_USER = """\
cmake_minimum_required(VERSION 3.14)
project(user C)
find_package(greeter REQUIRED)
if(BREAK_IN STREQUAL "configure")
  message(FATAL_ERROR "broken on purpose ${greeter_GREETING}")
endif()
add_executable(user user.c)
"""


@pytest.mark.parametrize("step", ["configure", "build"])
def test_a_failed_cmake_packages_reproduce_line_fails_the_same_way_in_a_fresh_shell(
        tmp_path: Path, step: str) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "greeter", GREETER_CONFIG)
    write_cmake(ws / "src", "user", BROKEN_USER, depend=["greeter"], files={
        "user.c": '#error "broken on purpose, compiling"\nint main(void) { return 0; }\n'})
    result = wsbuild("build", "--compiler-cache", "ccache", "--cmake-args",
                     f"-DBREAK_IN={step}", cwd=ws)
    assert result.returncode == 1, output(result)
    reproduce, script = _reproduce(result, ws)
    code = re.search(r"'cmake' exited with code (\d+)", result.stdout)
    assert code is not None, output(result)
    # nothing of this run's own: its jobserver's descriptors, the compiler cache's stats log
    assert "--jobserver-auth" not in script and "MAKEFLAGS" not in script
    assert "CCACHE_STATSLOG" not in script and "wsbuild-" not in script
    shown = ("broken on purpose from greeter" if step == "configure"
             else "broken on purpose, compiling")
    assert shown in result.stdout

    again = subprocess.run(["bash", "-c", reproduce], cwd=ws, env=clean_env(),
                           capture_output=True, text=True, timeout=120)
    assert again.returncode == int(code.group(1)), again.stdout + again.stderr
    assert shown in again.stdout + again.stderr


def test_a_merged_install_that_fails_is_reproduced_without_the_stage(tmp_path: Path) -> None:
    """A merged install stages through DESTDIR, a directory of that run only: the reproduce
    line installs where CMake was told to, and fails the same way."""
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "halfway", "cmake_minimum_required(VERSION 3.14)\n"
                "project(halfway NONE)\n"
                'install(CODE "message(FATAL_ERROR \\"install broken on purpose\\")")\n')
    result = wsbuild("build", "--merge-install", cwd=ws)
    assert result.returncode == 1, output(result)
    reproduce, script = _reproduce(result, ws)
    assert script.endswith(f"cmake --install {ws / 'build' / 'halfway'}\n")
    assert "DESTDIR" not in script
    assert "DESTDIR=" in (ws / "log" / "latest_build" / "halfway" / "command.log").read_text()
    again = subprocess.run(["bash", "-c", reproduce], cwd=ws, env=clean_env(),
                           capture_output=True, text=True, timeout=120)
    assert again.returncode != 0
    assert "install broken on purpose" in again.stdout + again.stderr


def test_a_failed_python_step_is_reproduced_by_its_by_hand_command(tmp_path: Path) -> None:
    """The Python build types' steps run inside wsbuild; a failed one is reproduced by the
    command that runs the same step from a shell."""
    ws = tmp_path / "ws"
    pkg = write_ament_python(ws / "src", "nosetup", modules={"main.py": VICTIM_MAIN})
    (pkg / "setup.py").unlink()
    (pkg / "setup.cfg").unlink()
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 1, output(result)
    shown = f"{pkg}: no setup.py, setup.cfg or pyproject.toml to build"
    assert shown in result.stdout
    reproduce, script = _reproduce(result, ws)
    assert "-m wsbuild.build_types.pybuild.by_hand configure --name nosetup" in script
    again = subprocess.run(["bash", "-c", reproduce], cwd=ws, env=clean_env(),
                           capture_output=True, text=True, timeout=120)
    assert again.returncode == 1, again.stdout + again.stderr
    assert again.stderr == f"error: {shown}\n"


def test_a_syntax_error_in_setup_py_names_setup_py_and_its_line(tmp_path: Path) -> None:
    """setuptools runs setup.py from a string (`File "<string>", line 11`) under the name of
    the interpreter: the failure names setup.py, the line and the error instead."""
    ws = tmp_path / "ws"
    pkg = write_ament_python(ws / "src", "typo_py", modules={"main.py": VICTIM_MAIN})
    setup_py = pkg / "setup.py"
    lines = setup_py.read_text().splitlines()
    number = next(i for i, line in enumerate(lines, 1) if line.strip().startswith("version="))
    lines[number - 1] = lines[number - 1].rstrip(",")  # a comma forgotten
    setup_py.write_text("\n".join(lines) + "\n")
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 1, output(result)
    failed = next(line for line in result.stdout.splitlines() if line.startswith("Failed"))
    assert failed.endswith(f"{setup_py}:{number}: SyntaxError: invalid syntax. Perhaps you "
                           "forgot a comma?"), output(result)
    assert "<string>" not in result.stdout and "exited with code" not in result.stdout


def _failure_ws(root: Path) -> Path:
    """aa_broken fails; bb_fine and cc_fine do not need it; dd_needs_aa does."""
    src = root / "src"
    _break(_data_package(src, "aa_broken"), "cmake-syntax")
    _data_package(src, "bb_fine")
    _data_package(src, "cc_fine")
    _data_package(src, "dd_needs_aa", ["aa_broken"])
    return root


def _summary(stdout: str) -> list[str]:
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Summary:"))
    return lines[start:]


def test_by_default_no_package_starts_after_a_failure(tmp_path: Path) -> None:
    ws = _failure_ws(tmp_path / "ws")
    result = wsbuild("build", "--executor", "sequential", cwd=ws)
    assert result.returncode == 1, output(result)
    assert "Starting >>> bb_fine" not in result.stdout
    summary = _summary(result.stdout)
    assert "  1 package failed: aa_broken" in summary, summary
    assert "  3 packages not processed: bb_fine cc_fine dd_needs_aa" in summary, summary
    for name in ("aa_broken", "bb_fine", "cc_fine", "dd_needs_aa"):
        assert not (ws / "install" / name).exists()


def test_continue_on_error_builds_everything_not_depending_on_the_failure(tmp_path: Path) -> None:
    ws = _failure_ws(tmp_path / "ws")
    result = wsbuild("build", "--executor", "sequential", "--continue-on-error", cwd=ws)
    assert result.returncode == 1, output(result)
    summary = _summary(result.stdout)
    assert summary[0].startswith("Summary: 2 packages finished"), summary
    assert "  1 package failed: aa_broken" in summary, summary
    assert "  1 package not processed: dd_needs_aa" in summary, summary
    assert (ws / "install" / "bb_fine" / "share" / "bb_fine" / "data.txt").is_file()
    assert (ws / "install" / "cc_fine" / "share" / "cc_fine" / "data.txt").is_file()
    assert not (ws / "install" / "dd_needs_aa").exists()


# ------------------------------------------------------------------- checks before building

def test_strict_unresolved_dependencies_are_reported_together_before_anything_builds(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    src = ws / "src"
    write_cmake(src, "needy", DATA_CMAKE.format(name="needy"), files={"data.txt": "x\n"},
                depend=["no_such_pkg"])
    with open(src / "needy" / "package.xml") as handle:
        xml = handle.read()
    (src / "needy" / "package.xml").write_text(xml.replace(
        "<depend>no_such_pkg</depend>",
        "<depend>no_such_pkg</depend>\n  <build_depend>python3-no-such-module</build_depend>"))
    write_cmake(src, "needy_too", DATA_CMAKE.format(name="needy_too"),
                files={"data.txt": "x\n"}, depend=["no_such_pkg"])

    result = wsbuild("build", "--strict-dependencies", cwd=ws)

    assert result.returncode == 2, output(result)
    errors = [line for line in result.stderr.splitlines() if line.startswith("wsbuild: error:")]
    assert len(errors) == 1, output(result)
    assert "no_such_pkg (needed by needy, needy_too)" in errors[0]
    assert "python3-no-such-module (needed by needy)" in errors[0]
    assert "--strict-dependencies" in errors[0]
    assert "Starting" not in result.stdout
    assert not (ws / "install" / "needy").exists()
    assert not (ws / "build" / "needy").exists()

    # without --strict-dependencies: a warning (tests/test_dependency_check.py), and the build
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 0, output(result)
    assert (ws / "install" / "needy" / "share" / "needy" / "data.txt").is_file()


def test_unknown_package_in_packages_select_suggests_and_changes_nothing(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _data_package(ws / "src", "navigation_core")
    build(ws)
    before = snapshot(ws / "install")
    result = wsbuild("build", "--packages-select", "navigation_cor", cwd=ws)
    assert result.returncode == 2, output(result)
    assert "navigation_cor" in result.stderr
    assert "navigation_core" in result.stderr  # the suggestion
    assert "Traceback" not in result.stderr
    assert snapshot(ws / "install") == before


@requires_ros
def test_a_misspelt_dependency_that_fails_the_build_gets_a_did_you_mean(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "typo", "cmake_minimum_required(VERSION 3.14)\nproject(typo NONE)\n"
                "find_package(std_msg REQUIRED)\n", depend=["std_msg"])
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 1, output(result)
    assert ("declares build dependency std_msg, which was not found (did you mean "
            "'std_msgs'?)") in result.stdout, output(result)
    # the warning before the build says the same, not rosdep or apt
    assert "    std_msg: not found (did you mean 'std_msgs'?)" in result.stdout, output(result)
    assert "rosdep" not in result.stdout, output(result)


@requires_ros
def test_a_dependency_without_a_wheel_is_named_so_by_pkg_create_and_the_failed_build(
        tmp_path: Path) -> None:
    """`rclcpp` is no typo of `rclpy`: it has no wheel. `pkg create` says at once what a C++
    node then needs, and the build failure says the same instead of a did-you-mean; a
    dependency nothing knows, on the pip underlay, is for `wsbuild deps install`."""
    ws = tmp_path / "ws"
    (ws / "src").mkdir(parents=True)
    created = wsbuild("pkg", "create", "cpp_pubsub", "--build-type", "ament_cmake",
                      "--dependencies", "rclcpp", "std_msgs", "some_unheard_of_thing", cwd=ws)
    assert created.returncode == 0, output(created)
    advice = ("rclcpp has no PyPI wheel: C++ nodes need `wsbuild deps install --from-source` "
              "(it fetches it and what it needs from the distro's index and builds them as "
              "your underlay; it needs the index and the source hosts reachable) or a full "
              "ROS 2 install (apt, then source it)")
    assert f"note: {advice}; until then `wsbuild build` of cpp_pubsub fails on it" \
        in created.stderr, output(created)
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 1, output(result)
    assert f"declares build dependency rclcpp, which was not found: {advice}" in result.stdout
    assert "did you mean 'rclpy'" not in result.stdout, output(result)
    assert ("some_unheard_of_thing: not found: `wsbuild deps install` looks for it (a wheel, "
            "a system package, its sources) and installs it") in result.stdout, output(result)


def test_bad_package_xml_is_one_line_naming_file_and_line(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    pkg = _data_package(ws / "src", "good_then_bad")
    build(ws)
    before = snapshot(ws / "install")
    manifest = pkg / "package.xml"
    lines = manifest.read_text().splitlines()
    number = next(i for i, line in enumerate(lines, 1) if "<version>" in line)
    lines[number - 1] = lines[number - 1].replace("</version>", "</versoin>")
    manifest.write_text("\n".join(lines) + "\n")

    result = wsbuild("build", cwd=ws)

    assert result.returncode == 2, output(result)
    stderr = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(stderr) == 1, output(result)
    assert stderr[0].startswith(f"wsbuild: error: {manifest}:{number}: ")
    assert snapshot(ws / "install") == before


AMENT_DATA_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(amented NONE)
find_package(ament_cmake REQUIRED)
install(FILES data.txt DESTINATION share/${PROJECT_NAME})
ament_package()
"""


@pytest.mark.parametrize(("written", "problem", "fix"), [
    ("  <sometool_tag>x</sometool_tag>\n",
     "unknown element <sometool_tag> (not part of package format 3)",
     "remove it, or put a tool's own element inside <export>"),
    ("  <deps>std_msgs</deps>\n", "unknown element <deps> (not part of package format 3)",
     "did you mean <depend>? Else remove it, or put a tool's own element inside <export>"),
    ('  <author email="a@b.c">Someone</author>\n', "invalid email 'a@b.c' of <author>",
     'write a full address, e.g. email="you@example.com"'),
], ids=["unknown-element", "near-a-known-one", "email"])
def test_what_ament_cmakes_manifest_reader_refuses_is_an_error_before_anything_runs(
        tmp_path: Path, written: str, problem: str, fix: str) -> None:
    """ament_cmake reads package.xml with catkin_pkg, which refuses what wsbuild reads past
    with a warning: for an ament_cmake package that is one line naming the file, the line and
    the fix before anything runs (install/ as it was); a plain CMake package, whose build
    reads no package.xml, builds with the warning."""
    ws = tmp_path / "ws"
    plain = write_cmake(ws / "src", "plain", DATA_CMAKE.format(name="plain"),
                        files={"data.txt": "plain\n"})
    ament = write_cmake(ws / "src", "amented", AMENT_DATA_CMAKE, build_type="ament_cmake",
                        files={"data.txt": "amented\n"})
    build(ws)
    before = snapshot(ws / "install")
    for pkg in (plain, ament):
        manifest = pkg / "package.xml"
        manifest.write_text(manifest.read_text().replace("  <export>", written + "  <export>"))
    line = (ament / "package.xml").read_text().splitlines().index(written.rstrip("\n")) + 1

    refused = wsbuild("build", cwd=ws)
    assert refused.returncode == 2, output(refused)
    assert refused.stderr.splitlines() == [
        f"wsbuild: error: {ament / 'package.xml'}:{line}: {problem}: ament_cmake's package.xml "
        f"reader (catkin_pkg) refuses it ({fix})"], output(refused)
    assert "Starting" not in refused.stdout and snapshot(ws / "install") == before

    alone = wsbuild("build", "--packages-select", "plain", cwd=ws)
    assert alone.returncode == 0, output(alone)
    assert f"{plain / 'package.xml'}:{line}: " in alone.stderr, output(alone)


WHY_BURIED = """\
cmake_minimum_required(VERSION 3.14)
project(buried NONE)
execute_process(COMMAND sh -c "echo 'ValueError: the reason it failed' >&2; exit 3"
                RESULT_VARIABLE failed)
foreach(i RANGE 20)
  message(STATUS "chatter ${i}")
endforeach()
if(failed)
  message(FATAL_ERROR "the generator failed")
endif()
"""


def test_a_failures_summary_quotes_the_line_that_says_why(tmp_path: Path) -> None:
    """The line that says why a step failed came long before its log's last lines: the
    summary quotes it first, then the tail."""
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "buried", WHY_BURIED)
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 1, output(result)
    failed = result.stdout.split("Failed   <<< buried", 1)[1].splitlines()
    assert failed[1].strip() == "ValueError: the reason it failed", output(result)
    assert failed[2].strip() == "...", output(result)


def test_failed_build_output_names_log_dir_in_the_final_error(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _break(_data_package(ws / "src", "victim"), "cmake-syntax")
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 1
    match = re.search(r"logs in (\S+?)\)", result.stderr)
    assert match, output(result)
    assert (Path(match.group(1)) / "victim" / "stdout_stderr.log").is_file()
    assert Path(match.group(1)).resolve() == (ws / "log" / "latest_build").resolve()




@pytest.mark.parametrize(("verb", "layout", "args", "searched"), [
    ("build", "empty", (), "."),
    ("build", "empty src", (), "src"),
    ("build", "packages elsewhere", ("--base-paths", "nowhere"), "nowhere"),
    ("test", "empty src", (), "src"),
])
def test_no_packages_found_is_one_line_naming_where_and_nothing_is_written(
        tmp_path: Path, verb: str, layout: str, args: tuple[str, ...], searched: str) -> None:
    ws = tmp_path / "ws"
    ws.mkdir()
    if layout == "empty src":
        (ws / "src").mkdir()
    if layout == "packages elsewhere":
        _data_package(ws / "src", "somewhere")
    before = sorted(p.relative_to(ws) for p in ws.rglob("*"))
    result = wsbuild(verb, *args, cwd=ws)
    assert result.returncode == 2, output(result)
    where = ws if searched == "." else ws / searched
    assert result.stderr.splitlines() == [
        f"wsbuild: error: no packages found in {where}; nothing to do, nothing written ("
        + (f"{where} does not exist; " if layout == "packages elsewhere" else "")
        + f"a package is a directory holding a package.xml: create one in {ws / 'src'} with "
        "`wsbuild pkg create NAME`, or run wsbuild in the workspace that holds yours, or give "
        "--base-paths)"], output(result)
    assert sorted(p.relative_to(ws) for p in ws.rglob("*")) == before


def test_a_runtime_error_in_setup_py_names_setup_py_and_its_line(tmp_path: Path) -> None:
    """setuptools runs setup.py from a string (`File "<string>", line 23`): the failure's
    first line names setup.py and the line, as for a syntax error."""
    ws = tmp_path / "ws"
    pkg = write_ament_python(ws / "src", "namer", modules={"main.py": VICTIM_MAIN})
    setup = pkg / "setup.py"
    lines = setup.read_text().splitlines()
    number = next(i for i, line in enumerate(lines, 1) if line.startswith("setup("))
    lines.insert(number - 1, "undefined_name")
    setup.write_text("\n".join(lines) + "\n")
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 1, output(result)
    failed = result.stdout.split("Failed   <<< namer", 1)[1].splitlines()
    assert failed[1].strip() == \
        f"{setup}:{number}: NameError: name 'undefined_name' is not defined", output(result)
