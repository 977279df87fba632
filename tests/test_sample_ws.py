"""End to end: build sample_ws/ with wsbuild, then run its nodes, service, xacro and C++ app."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from conftest import sigint_at_default
from wsbuild.underlay.detect import find_venv_underlay

REPO = Path(__file__).resolve().parent.parent
SAMPLE_WS = REPO / "sample_ws"
UNDERLAY = find_venv_underlay(os.environ, sys.executable)

pytestmark = [
    pytest.mark.ros,
    pytest.mark.slow,
    # one worker builds the workspace once and runs every test against it
    pytest.mark.xdist_group("sample_ws"),
    pytest.mark.skipif(UNDERLAY is None,
                       reason="the running interpreter's venv has no ROS underlay"),
    pytest.mark.skipif(not (shutil.which("cmake") and shutil.which("c++")),
                       reason="cmake or a C++ compiler is missing (see scripts/setup.sh)"),
]

PACKAGES = {
    "demo_cpp_app": "ament_cmake",
    "demo_cpp_lib": "ament_cmake",
    "demo_description": "ament_cmake",
    "demo_interfaces": "ament_cmake",
    "demo_nodes_py": "ament_python",
    "demo_parts": "ament_cmake",
    "demo_tools": "cmake",
}
# demo_tools is a plain CMake package: colcon puts it on CMAKE_PREFIX_PATH and PATH, not
# into the ament index, so it is found through those instead (see test_plain_cmake_package...).
AMENT_PACKAGES = sorted(set(PACKAGES) - {"demo_tools"})

WSBUILD = f"{shlex.quote(sys.executable)} -m wsbuild"
PYTHON = shlex.quote(sys.executable)
# `$(...)` printing a package's share directory, found through the ament index
SHARE = (f'$({PYTHON} -c "from ament_index_python.packages import '
         'get_package_share_directory as g; print(g(\'{package}\'))")')
SETPOINT_LINE = re.compile(r"\[move_joint\]: (?P<joint>\w+) <- (?P<value>[+-]\d+\.\d{3}) rad")


def _domain_id() -> str:
    """60 + the pytest-xdist worker number: parallel test sessions never see each other."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    return str(60 + int(worker.removeprefix("gw") or 0))


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env.update(
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_DOMAIN_ID=_domain_id(),
        PYTHONUNBUFFERED="1",
        RCUTILS_LOGGING_BUFFERED_STREAM="0",
        RCUTILS_COLORIZED_OUTPUT="0",
    )
    return env


@dataclass(frozen=True, slots=True)
class Workspace:
    root: Path
    build_output: str

    def source(self, script: str) -> list[str]:
        """A bash command line running `script` in the sourced workspace."""
        return ["bash", "-c", f"source install/setup.bash && {script}"]

    def bash(self, script: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
        return subprocess.run(self.source(script), cwd=self.root, env=_environment(),
                              capture_output=True, text=True, timeout=timeout)

    def share(self, package: str) -> Path:
        """`share/<package>` in the isolated install layout."""
        return self.root / "install" / package / "share" / package


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Workspace:
    """A copy of sample_ws/ built once (about 20 s on two cores) for the whole module."""
    root = tmp_path_factory.mktemp("sample_ws")
    # a sample_ws built in place (scripts/demo.sh) must not leak its build into the copy
    shutil.copytree(SAMPLE_WS / "src", root / "src",
                    ignore=shutil.ignore_patterns("__pycache__", ".pytest_cache"))
    result = subprocess.run([sys.executable, "-m", "wsbuild", "build"], cwd=root,
                            env=_environment(), capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"wsbuild build failed:\n{result.stdout}\n{result.stderr}"
    return Workspace(root=root, build_output=result.stdout + result.stderr)


class Running:
    """A process started in its own process group whose merged output is read as it comes."""

    def __init__(self, command: list[str], cwd: Path) -> None:
        self.command = command
        self.popen = subprocess.Popen(command, cwd=cwd, env=_environment(), text=True,
                                      stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                      start_new_session=True, preexec_fn=sigint_at_default)
        self.lines: list[str] = []
        self._eof = False
        self._changed = threading.Condition()
        self._reader = threading.Thread(target=self._pump, daemon=True)
        self._reader.start()

    def _pump(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            with self._changed:
                self.lines.append(line)
                self._changed.notify_all()
        with self._changed:
            self._eof = True
            self._changed.notify_all()

    @property
    def output(self) -> str:
        with self._changed:
            return "".join(self.lines)

    def wait_for(self, pattern: str | re.Pattern[str], timeout: float = 30) -> re.Match[str]:
        """The first output line matching `pattern`; fails on exit or after `timeout` seconds."""
        regex = re.compile(pattern)
        deadline = time.monotonic() + timeout
        seen = 0
        with self._changed:
            while True:
                for line in self.lines[seen:]:
                    if match := regex.search(line):
                        return match
                seen = len(self.lines)
                if self._eof:
                    self.popen.wait()
                    pytest.fail(f"{self.command[-1]!r} exited with {self.popen.returncode} "
                                f"before printing {regex.pattern!r}; output:\n{self.output}")
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    pytest.fail(f"no {regex.pattern!r} from {self.command[-1]!r} within "
                                f"{timeout} s; output:\n{''.join(self.lines)}")
                self._changed.wait(remaining)

    def stop(self) -> None:
        """SIGINT to the whole group (nodes shut down cleanly), SIGKILL if that is not enough."""
        if self.popen.poll() is None:
            for sig, grace in ((signal.SIGINT, 5.0), (signal.SIGKILL, 5.0)):
                try:
                    os.killpg(self.popen.pid, sig)
                except ProcessLookupError:
                    break
                try:
                    self.popen.wait(grace)
                    break
                except subprocess.TimeoutExpired:
                    continue
        self._reader.join(5)


@pytest.fixture
def start(workspace: Workspace) -> Iterator[Callable[[str], Running]]:
    """`start("wsbuild run ...")` in the sourced workspace; everything started is stopped after."""
    started: list[Running] = []

    def run(script: str) -> Running:
        process = Running(workspace.source(f"exec {script}"), workspace.root)
        started.append(process)
        return process

    try:
        yield run
    finally:
        for process in reversed(started):
            process.stop()


def _built_packages(output: str) -> list[str]:
    return sorted(re.findall(r"^Starting >>> (\S+)", output, flags=re.MULTILINE))


# ---------------------------------------------------------------------------------- build


def test_the_whole_workspace_builds_every_package(workspace: Workspace) -> None:
    assert _built_packages(workspace.build_output) == sorted(PACKAGES)
    assert "Summary: 7 packages finished" in workspace.build_output


def test_wsbuild_list_shows_every_package_with_its_build_type(workspace: Workspace) -> None:
    result = subprocess.run([sys.executable, "-m", "wsbuild", "list"], cwd=workspace.root,
                            env=_environment(), capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    listed = {}
    for line in result.stdout.splitlines():
        name, _path, build_type = line.split("\t")
        listed[name] = build_type.strip("()")
    assert listed == PACKAGES


# ------------------------------------------------------------------------------ the nodes


def test_move_joint_receives_the_published_setpoints_through_a_remap(
        workspace: Workspace, start: Callable[[str], Running]) -> None:
    listener = start(f"{WSBUILD} run demo_nodes_py move_joint "
                     "--ros-args -r /joint_setpoint:=/setpoint -p joint_name:=right_e0")
    ready = listener.wait_for(r"move_joint ready: joint (\S+), max_velocity (\S+), "
                              r"listening on (\S+)")
    # the default max_velocity (the params file sets 0.75) and the remapped topic
    assert ready.groups() == ("right_e0", "1.0", "/setpoint")
    start(f"{WSBUILD} run demo_nodes_py setpoint_publisher")
    received = listener.wait_for(SETPOINT_LINE)
    assert received["joint"] == "right_e0"
    assert -1.0 <= float(received["value"]) <= 1.0  # the publisher's default amplitude


@pytest.mark.parametrize(("node", "ready"), [("setpoint_publisher", "publishing on"),
                                             ("move_joint", "move_joint ready"),
                                             ("mode_server", "serving")])
def test_the_nodes_stop_cleanly_on_ctrl_c_also_under_ros2_launch(
        start: Callable[[str], Running], node: str, ready: str) -> None:
    process = start(f"install/demo_nodes_py/lib/demo_nodes_py/{node} "
                    "--ros-args -p joint_name:=right_e0")
    process.wait_for(ready)
    time.sleep(0.5)  # spinning (see test_sigint.py)
    os.killpg(process.popen.pid, signal.SIGINT)  # Ctrl-C: the whole foreground group
    time.sleep(0.02)
    try:
        os.kill(process.popen.pid, signal.SIGINT)  # ros2 launch passes it on to each node
    except ProcessLookupError:
        pass
    assert process.popen.wait(15) == 0, process.output  # launch: "exit code -2" otherwise
    process.stop()
    assert "Traceback" not in process.output, process.output


def test_move_joint_without_joint_name_fails_with_a_clear_message(workspace: Workspace) -> None:
    result = workspace.bash(f"{WSBUILD} run demo_nodes_py move_joint")
    assert result.returncode == 2
    assert "move_joint: error: parameter 'joint_name' is required" in result.stderr
    assert "-p joint_name:=" in result.stderr


def test_the_client_gets_the_answer_of_the_change_mode_server(
        workspace: Workspace, start: Callable[[str], Running]) -> None:
    server = start(f"{WSBUILD} run demo_nodes_py mode_server")
    server.wait_for(r"serving \S*change_mode in idle mode")
    switched = workspace.bash(f"{WSBUILD} run demo_nodes_py change_mode_client velocity "
                              "--timeout 20")
    assert switched.returncode == 0, switched.stdout + switched.stderr
    assert switched.stdout.strip() == ("success=True previous_mode=idle "
                                       "message=switched from idle to velocity")
    refused = workspace.bash(f"{WSBUILD} run demo_nodes_py change_mode_client warp --timeout 20")
    assert refused.returncode == 3, refused.stdout + refused.stderr
    assert "success=False previous_mode=velocity message=unknown mode 'warp'" in refused.stdout
    server.wait_for(r"request 'warp': unknown mode")


def test_the_params_file_applies_to_move_joint_in_any_namespace(
        workspace: Workspace, start: Callable[[str], Running]) -> None:
    params = SHARE.format(package="demo_nodes_py") + "/config/params.yaml"
    node = start(f'{WSBUILD} run demo_nodes_py move_joint --ros-args -r __ns:=/arm '
                 f'--params-file "{params}"')
    ready = node.wait_for(r"move_joint ready: joint (\S+), max_velocity (\S+), listening on (\S+)")
    # joint_name and max_velocity only come from the YAML; the launch files use /arm too
    assert ready.groups() == ("left_s1", "0.75", "/arm/joint_setpoint")


# ---------------------------------------------------------------- description, C++, index


def test_xacro_expands_the_robot_with_the_arm_macro_of_demo_parts(workspace: Workspace) -> None:
    urdf = SHARE.format(package="demo_description") + "/urdf/robot.urdf.xacro"
    result = workspace.bash(f'xacro "{urdf}"')
    assert result.returncode == 0, result.stderr
    robot = ET.fromstring(result.stdout)
    assert robot.get("name") == "demo_robot"
    # joints and links that only demo_parts/urdf/arm.xacro defines
    assert sorted(j.get("name") for j in robot.iter("joint")) == [
        "left_e0", "left_s0", "right_e0", "right_s0"]
    assert {"base_link", "left_forearm", "right_upper_arm"} <= {
        link.get("name") for link in robot.iter("link")}
    one_arm = workspace.bash(f'xacro "{urdf}" arms:=left')
    assert one_arm.returncode == 0, one_arm.stderr
    assert sorted(j.get("name") for j in ET.fromstring(one_arm.stdout).iter("joint")) == [
        "left_e0", "left_s0"]


def test_the_cpp_app_prints_the_result_of_its_library(workspace: Workspace) -> None:
    result = workspace.bash(f"{WSBUILD} run demo_cpp_app joint_command right_e0 90")
    assert result.returncode == 0, result.stderr
    assert result.stdout == "right_e0: 90.0 deg -> 1.571 rad (limits [-3.05, 3.05])\n"
    clamped = workspace.bash(f"{WSBUILD} run demo_cpp_app joint_command right_e0 400")
    assert clamped.stdout == "right_e0: 400.0 deg -> 3.050 rad (limits [-3.05, 3.05])\n"
    # linked against the shared library installed by demo_cpp_lib, not a copy
    assert (workspace.root / "install/demo_cpp_lib/lib/libdemo_cpp_lib.so").is_file()


def test_the_cpp_library_gtest_was_built_and_passes(workspace: Workspace) -> None:
    result = subprocess.run(["ctest", "--test-dir", "build/demo_cpp_lib", "--output-on-failure"],
                            cwd=workspace.root, env=_environment(), capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "100% tests passed, 0 tests failed out of 1" in result.stdout


def test_plain_cmake_package_is_on_path_and_cmake_prefix_path(workspace: Workspace) -> None:
    result = workspace.bash('demo_tools_version && echo "$CMAKE_PREFIX_PATH"')
    assert result.returncode == 0, result.stderr
    version, prefixes = result.stdout.splitlines()
    assert version == "demo_tools 0.1.0"
    assert str(workspace.root / "install" / "demo_tools") in prefixes.split(os.pathsep)
    config = workspace.root / "install/demo_tools/share/demo_tools/cmake/demo_toolsConfig.cmake"
    assert config.is_file()


def test_the_ament_index_finds_every_package_and_its_installed_files(
        workspace: Workspace) -> None:
    script = (
        "from ament_index_python.packages import get_package_share_directory as g\n"
        f"for name in {AMENT_PACKAGES!r}:\n"
        "    print(name, g(name))\n"
    )
    result = workspace.bash(f"{PYTHON} -c {shlex.quote(script)}")
    assert result.returncode == 0, result.stderr
    found = dict(line.split(" ", 1) for line in result.stdout.splitlines())
    assert found == {name: str(workspace.share(name)) for name in AMENT_PACKAGES}
    share = workspace.share("demo_nodes_py")
    installed = sorted(str(p.relative_to(share)) for p in share.rglob("*")
                       if p.parent.name in ("launch", "config"))
    assert installed == ["config/params.yaml", "launch/demo.launch.py",
                         "launch/demo.launch.xml", "launch/demo.launch.yaml"]
    assert (workspace.share("demo_parts") / "urdf" / "arm.xacro").is_file()


def test_the_installed_launch_and_config_files_are_well_formed(workspace: Workspace) -> None:
    share = workspace.share("demo_nodes_py")
    compiled = subprocess.run(
        [sys.executable, "-c", "import py_compile, sys; py_compile.compile(sys.argv[1], "
         "cfile=sys.argv[2], doraise=True)", str(share / "launch/demo.launch.py"),
         str(workspace.root / "demo.launch.pyc")],
        capture_output=True, text=True, timeout=60)
    assert compiled.returncode == 0, compiled.stderr
    xml_launch = ET.parse(share / "launch/demo.launch.xml").getroot()
    assert xml_launch.tag == "launch"
    move_joint = next(n for n in xml_launch.iter("node") if n.get("exec") == "move_joint")
    assert move_joint.find("remap").attrib == {"from": "joint_setpoint", "to": "setpoint"}
    yaml_launch = yaml.safe_load((share / "launch/demo.launch.yaml").read_text())
    nodes = [entry["node"] for entry in yaml_launch["launch"] if "node" in entry]
    assert [n["exec"] for n in nodes] == ["setpoint_publisher", "move_joint", "mode_server"]
    assert nodes[2]["if"] == "$(var with_mode_server)"
    params = yaml.safe_load((share / "config/params.yaml").read_text())
    assert params["/**/move_joint"]["ros__parameters"]["joint_name"] == "left_s1"


def test_the_generated_interfaces_import_in_python(workspace: Workspace) -> None:
    script = ("from demo_interfaces.msg import Setpoint\n"
              "from demo_interfaces.srv import ChangeMode\n"
              "print(Setpoint(joint_name='right_e0').joint_name, "
              "ChangeMode.Request(mode='idle').mode)")
    result = workspace.bash(f"{PYTHON} -c {shlex.quote(script)}")
    assert result.returncode == 0, result.stderr
    assert result.stdout == "right_e0 idle\n"


def test_the_python_package_tests_pass(workspace: Workspace) -> None:
    result = workspace.bash(f"{PYTHON} -m pytest -q -p no:cacheprovider src/demo_nodes_py/test")
    assert result.returncode == 0, result.stdout + result.stderr
    assert re.search(r"\b\d+ passed\b", result.stdout), result.stdout


# ------------------------------------------------------------------------------- rebuild


def test_an_edit_rebuilds_only_its_package_and_shows_when_run(workspace: Workspace) -> None:
    source = workspace.root / "src/demo_nodes_py/demo_nodes_py/change_mode_client.py"
    text = source.read_text()
    assert "USAGE = 'usage: change_mode_client" in text
    source.write_text(text.replace("USAGE = 'usage: change_mode_client",
                                   "USAGE = 'edited usage: change_mode_client"))
    result = subprocess.run(
        [sys.executable, "-m", "wsbuild", "build", "--packages-select", "demo_nodes_py"],
        cwd=workspace.root, env=_environment(), capture_output=True, text=True, timeout=300)
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    assert _built_packages(output) == ["demo_nodes_py"]
    assert "Summary: 1 package finished" in output
    run = workspace.bash(f"{WSBUILD} run demo_nodes_py change_mode_client")
    assert run.returncode == 2
    assert "edited usage: change_mode_client MODE" in run.stderr


def test_the_interfaces_built_again_from_clean_keep_every_header(workspace: Workspace) -> None:
    """`--cmake-clean-first` (and a rebuild of everything for a changed variable the build
    step read) cleans before the configure: the visibility headers rosidl writes at configure
    time are installed again (a clean after it deleted them for good)."""
    header = (workspace.root / "install" / "demo_interfaces" / "include" / "demo_interfaces"
              / "demo_interfaces" / "msg" / "rosidl_generator_cpp__visibility_control.hpp")
    assert header.is_file()
    result = subprocess.run(
        [sys.executable, "-m", "wsbuild", "build", "--packages-select", "demo_interfaces",
         "--cmake-clean-first"],
        cwd=workspace.root, env=_environment(), capture_output=True, text=True, timeout=600)
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    assert _built_packages(output) == ["demo_interfaces"], output
    assert header.is_file(), output
