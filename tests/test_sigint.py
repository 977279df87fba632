"""Nodes made by `wsbuild pkg create` stop cleanly on Ctrl-C: exit code 0, no traceback.

Ctrl-C in a terminal sends SIGINT to the whole foreground process group; under `ros2 launch`
the launch process then sends each node a SIGINT of its own, a few milliseconds later. A node
that dies of that second signal shows up as "process has died [exit code -2]".
(sample_ws's own nodes get the same check in test_sample_ws.py, against its one build.)
"""

from __future__ import annotations

import os
import select
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import run_wsbuild, sigint_at_default
from wsbuild.underlay.detect import find_venv_underlay

ROS = find_venv_underlay(os.environ, sys.executable)

pytestmark = [
    pytest.mark.ros,
    pytest.mark.slow,
    pytest.mark.skipif(ROS is None, reason="needs the ROS 2 wheel underlay"),
]


def _environment() -> dict[str, str]:
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    return dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                ROS_DOMAIN_ID=str(140 + int(worker.removeprefix("gw") or 0)),
                PYTHONUNBUFFERED="1", RCUTILS_LOGGING_BUFFERED_STREAM="0",
                RCUTILS_COLORIZED_OUTPUT="0")


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    ws = tmp_path_factory.mktemp("sigint") / "ws"
    (ws / "src").mkdir(parents=True)
    created = run_wsbuild("pkg", "create", "sig_pkg", "--build-type", "ament_python",
                          "--dependencies", "rclpy", "--node-name", "talker", cwd=ws,
                          env=_environment())
    assert created.returncode == 0, created.stderr
    built = run_wsbuild("build", cwd=ws, env=_environment())
    assert built.returncode == 0, built.stdout + built.stderr
    return ws


def _start(ws: Path) -> subprocess.Popen[bytes]:
    """The node as `ros2 launch` starts it: its installed executable, in its own group."""
    script = ("source install/setup.bash && "
              f"exec {shlex.quote(str(ws / 'install/sig_pkg/lib/sig_pkg/talker'))}")
    return subprocess.Popen(["bash", "-c", script], cwd=ws, env=_environment(),
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            start_new_session=True, preexec_fn=sigint_at_default)


def _wait_for(process: subprocess.Popen[bytes], text: str, timeout: float = 30) -> bytes:
    assert process.stdout is not None
    seen = b""
    deadline = time.monotonic() + timeout
    while text.encode() not in seen:
        remaining = deadline - time.monotonic()
        if remaining <= 0 or process.poll() is not None:
            pytest.fail(f"no {text!r} from the node; output:\n{seen.decode(errors='replace')}")
        ready, _, _ = select.select([process.stdout], [], [], min(remaining, 0.2))
        if ready:
            seen += os.read(process.stdout.fileno(), 65536)
    return seen


@pytest.mark.parametrize("launch_gap", [None, 0.0, 0.05], ids=["ctrl-c", "with-launch-at-once",
                                                                "with-launch-50ms-later"])
def test_the_node_exits_0_without_traceback_on_sigint(workspace: Path,
                                                       launch_gap: float | None) -> None:
    process = _start(workspace)
    try:
        output = _wait_for(process, "greeting: Hello from talker")
        # spinning by now (a signal between the node's constructor and rclpy.spin() can meet
        # rclpy's executor half-built: its __del__ then prints an "Exception ignored")
        time.sleep(0.5)
        os.killpg(process.pid, signal.SIGINT)  # the terminal's Ctrl-C
        if launch_gap is not None:
            time.sleep(launch_gap)
            try:
                os.kill(process.pid, signal.SIGINT)  # ros2 launch passing the Ctrl-C on
            except ProcessLookupError:
                pass  # already gone: fine
        rest, _ = process.communicate(timeout=15)
        output += rest
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    text = output.decode(errors="replace")
    assert process.returncode == 0, text
    assert "Traceback" not in text, text
