"""What colcon's options do when wsbuild runs them: event handlers (console_stderr-, status-
on a terminal), mixins (over http, from COLCON_MIXIN_PATH), colcon.meta, --log-base (and
/dev/null), test --abort-on-error, WSBUILD_CACHE_TIMEOUT, the last 10 runs kept, and the
selections by previous results, on real builds."""

from __future__ import annotations

import contextlib
import functools
import http.server
import os
import pty
import re
import select
import shutil
import socket
import ssl
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from conftest import REPO, run_wsbuild
from test_build_helpers import requires_ros

MIXIN_INDEX = Path(__file__).resolve().parent / "data" / "mixin_index"

FAILING_CMAKE = """cmake_minimum_required(VERSION 3.14)
project({name} NONE)
message(FATAL_ERROR "{name} does not build")
"""


def env_with(home: Path) -> dict[str, str]:
    return {**os.environ, "COLCON_HOME": str(home)}


def cache_entry(build_dir: Path, name: str) -> str | None:
    for line in (build_dir / "CMakeCache.txt").read_text().splitlines():
        if line.startswith(f"{name}:"):
            return line.partition("=")[2]
    return None


@pytest.mark.slow
@requires_ros
def test_sample_ws_with_a_mixin_live_output_and_colcon_meta(tmp_path: Path) -> None:
    """`colcon build --mixin release --event-handlers console_direct+ --metas …` on sample_ws:
    compiler lines stream before the package finishes, the mixin's CMAKE_BUILD_TYPE reaches the
    CMake cache, and colcon.meta's argument reaches only the package it names."""
    ws = tmp_path / "ws"
    shutil.copytree(REPO / "sample_ws" / "src", ws / "src",
                    ignore=shutil.ignore_patterns("__pycache__", ".pytest_cache"))
    home = tmp_path / "colcon_home"
    shutil.copytree(MIXIN_INDEX, home / "mixin" / "default")
    (ws / "meta").mkdir()
    (ws / "meta" / "colcon.meta").write_text(
        '{"names": {"demo_cpp_app": {"cmake-args": ["-DWSBUILD_META_PROBE=reached"]}}}\n')
    result = run_wsbuild("build", "--packages-up-to", "demo_cpp_app", "--mixin", "release",
                         "--event-handlers", "console_direct+", "--metas", "meta/colcon.meta",
                         cwd=ws, env=env_with(home))
    assert result.returncode == 0, result.stdout + result.stderr
    lines = result.stdout.splitlines()
    compiled = next(i for i, line in enumerate(lines) if "joint_limits.cpp" in line)
    assert compiled < lines.index(next(x for x in lines if x.startswith(
        "Finished <<< demo_cpp_lib")))
    for name in ("demo_cpp_lib", "demo_cpp_app"):
        assert cache_entry(ws / "build" / name, "CMAKE_BUILD_TYPE") == "Release"
    assert cache_entry(ws / "build" / "demo_cpp_app", "WSBUILD_META_PROBE") == "reached"
    assert cache_entry(ws / "build" / "demo_cpp_lib", "WSBUILD_META_PROBE") is None


def test_console_cohesion_package_list_start_end_and_summary(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pc": ("cmake", []), "pd": ("cmake", ["pc"])})
    result = run_wsbuild("build", "--event-handlers", "console_cohesion+",
                         "console_package_list+", cwd=ws)
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert out.startswith("Topological order\n- pc (cmake)\n- pd (cmake)\n")
    block = out.index("--- output: pc\n")
    assert block < out.index("-- Configuring done", block) < out.index("\n---\n", block) \
        < out.index("Finished <<< pc")
    quiet = run_wsbuild("build", "--force", "--event-handlers", "console_start_end-",
                        "summary-", cwd=ws)
    assert quiet.returncode == 0, quiet.stderr
    assert "Starting >>>" not in quiet.stdout and "Finished <<<" not in quiet.stdout
    assert "Summary:" not in quiet.stdout


def test_global_log_base(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pc": ("cmake", [])})
    result = run_wsbuild("--log-base", "my_logs", "build", cwd=ws)
    assert result.returncode == 0, result.stderr
    assert (ws / "my_logs" / "latest_build" / "pc" / "command.log").is_file()
    assert not (ws / "log").exists()
    discarded = run_wsbuild("--log-base", os.devnull, "build", "--force", cwd=ws)
    assert discarded.returncode == 0, discarded.stderr
    assert not (ws / "log").exists()


def test_build_failed_and_build_finished_selections(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pa": ("cmake", []), "pb": ("cmake", []), "pc": ("cmake", ["pb"])})
    cmakelists = ws / "src" / "pb" / "CMakeLists.txt"
    working = cmakelists.read_text()
    cmakelists.write_text(FAILING_CMAKE.format(name="pb"))
    failed = run_wsbuild("build", "--continue-on-error", cwd=ws)
    assert failed.returncode == 1, failed.stdout + failed.stderr

    def listed(*options: str) -> list[str]:
        result = run_wsbuild("list", "-n", *options, cwd=ws)
        assert result.returncode == 0, result.stderr
        return result.stdout.split()

    assert listed("--packages-select-build-failed") == ["pb"]
    assert listed("--packages-skip-build-finished") == ["pb", "pc"]  # pc never built
    cmakelists.write_text(working)
    again = run_wsbuild("build", "--packages-select-build-failed", cwd=ws)
    assert again.returncode == 0, again.stderr
    assert "Finished <<< pb" in again.stdout and "<<< pc" not in again.stdout
    assert listed("--packages-select-build-failed") == []
    assert listed("--packages-skip-build-finished") == ["pc"]


JUNIT = """<?xml version="1.0" encoding="utf-8"?>
<testsuite name="pytest" tests="1" failures="{failures}" errors="0" skipped="0">
  <testcase classname="test_x" name="test_one">{failure}</testcase>
</testsuite>
"""


def test_test_failures_and_test_passed_selections(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"p_fail": ("cmake", []), "p_pass": ("cmake", []),
                         "p_none": ("cmake", [])})
    for name, failures in (("p_fail", 1), ("p_pass", 0)):
        results = ws / "build" / name / "test_results" / name
        results.mkdir(parents=True)
        failure = '<failure message="assert 1 == 2">assert 1 == 2</failure>' if failures else ""
        (results / "pytest.xml").write_text(JUNIT.format(failures=failures, failure=failure))
    for options, expected in ((["--packages-select-test-failures"], ["p_fail"]),
                              (["--packages-skip-test-passed"], ["p_fail", "p_none"])):
        result = run_wsbuild("list", "-n", *options, cwd=ws)
        assert result.returncode == 0, result.stderr
        assert result.stdout.split() == expected, options
    both = run_wsbuild("list", "--packages-select-test-failures",
                       "--packages-skip-test-passed", cwd=ws)
    assert both.returncode == 2 and "not allowed with argument" in both.stderr


def test_colcons_own_result_files_count_too(make_workspace: Callable[..., Path]) -> None:
    """A workspace colcon built last: its colcon_build.rc files."""
    ws = make_workspace({"pa": ("cmake", []), "pb": ("cmake", []), "pc": ("cmake", [])})
    for name, rc in (("pa", "0"), ("pb", "1"), ("pc", "SIGINT")):
        (ws / "build" / name).mkdir(parents=True)
        (ws / "build" / name / "colcon_build.rc").write_text(rc + "\n")
    result = run_wsbuild("list", "-n", "--packages-select-build-failed", cwd=ws)
    assert result.stdout.split() == ["pb"]  # colcon: an aborted build is not a failure
    result = run_wsbuild("list", "-n", "--packages-skip-build-finished", cwd=ws)
    assert result.stdout.split() == ["pb", "pc"]


def test_test_result_delete_yes_removes_the_result_files(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"p_fail": ("cmake", [])})
    results = ws / "build" / "p_fail" / "test_results" / "p_fail"
    results.mkdir(parents=True)
    (results / "pytest.xml").write_text(JUNIT.format(failures=0, failure=""))
    asked = run_wsbuild("test-result", "--delete", cwd=ws)  # stdin is not a terminal: refuses
    assert asked.returncode == 2 and "--delete-yes" in asked.stderr
    assert (results / "pytest.xml").exists()
    deleted = run_wsbuild("test-result", "--delete-yes", cwd=ws)
    assert deleted.returncode == 0, deleted.stderr
    assert not (results / "pytest.xml").exists()


def test_info_without_names_describes_the_selected_packages(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pa": ("cmake", []), "pb": ("cmake", ["pa"])})
    result = run_wsbuild("info", "--packages-select", "pb", cwd=ws)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("pb\n") and "\npa\n" not in result.stdout
    everything = run_wsbuild("info", cwd=ws)
    assert everything.stdout.startswith("pa\n") and "\n\npb\n" in everything.stdout


# ----------------------------------------------------------- effects, not just parsing (#32)

WARNING_CMAKE = """cmake_minimum_required(VERSION 3.14)
project({name} NONE)
message(WARNING "{name} probe warning")
"""


def test_console_stderr_off_hides_a_packages_warnings(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pw": ("cmake", [])})
    (ws / "src" / "pw" / "CMakeLists.txt").write_text(WARNING_CMAKE.format(name="pw"))
    shown = run_wsbuild("build", cwd=ws)
    assert shown.returncode == 0, shown.stderr
    assert "--- warnings: pw" in shown.stdout and "pw probe warning" in shown.stdout
    hidden = run_wsbuild("build", "--force", "--cmake-force-configure", "--event-handlers",
                         "console_stderr-", cwd=ws)
    assert hidden.returncode == 0, hidden.stderr
    assert "probe warning" not in hidden.stdout + hidden.stderr
    assert "Finished <<< pw" in hidden.stdout
    # the warning is still in the package's log
    assert "pw probe warning" in (ws / "log" / "latest_build" / "pw" /
                                  "stdout_stderr.log").read_text()


def _on_a_terminal(ws: Path, *args: str) -> tuple[int, str]:
    """Run `wsbuild ARGS` with a pseudo-terminal as its output; its exit code and output."""
    master, slave = pty.openpty()
    process = subprocess.Popen([sys.executable, "-m", "wsbuild", *args], cwd=ws,
                               stdin=subprocess.DEVNULL, stdout=slave, stderr=slave,
                               env={**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    os.close(slave)
    output = b""
    try:
        while True:
            ready, _, _ = select.select([master], [], [], 60)
            if not ready:
                break
            try:
                chunk = os.read(master, 4096)
            except OSError:  # EIO: the other side closed
                break
            if not chunk:
                break
            output += chunk
        return process.wait(timeout=60), output.decode(errors="replace")
    finally:
        os.close(master)
        if process.poll() is None:
            process.kill()
            process.wait()


def test_status_off_draws_no_status_line_on_a_terminal(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pc": ("cmake", []), "pd": ("cmake", ["pc"])})
    code, live = _on_a_terminal(ws, "build")
    assert code == 0, live
    # drawn when a package starts: "\r[0.1s] [0/2 done] [>   ] [pc:configure - 0.0s]\x1b[K"
    assert re.search(r"\r\[\d+\.\ds\] \[\d/2 done", live) and "\x1b[K" in live, live
    code, quiet = _on_a_terminal(ws, "build", "--force", "--event-handlers", "status-")
    assert code == 0, quiet
    assert "\x1b[K" not in quiet and " done" not in quiet.replace("Finished", ""), quiet
    assert "Finished <<< pd" in quiet


def test_log_base_dev_null_leaves_no_log_anywhere(make_workspace: Callable[..., Path],
                                                  tmp_path: Path) -> None:
    ws = make_workspace({"pc": ("cmake", [])})
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    env = {**os.environ, "TMPDIR": str(temporary)}
    for argv in (["build", "--log-base", os.devnull],
                 ["--log-base", os.devnull, "build", "--force"]):
        done = run_wsbuild(*argv, cwd=ws, env=env)
        assert done.returncode == 0, done.stderr
        assert "Finished <<< pc" in done.stdout
        assert not (ws / "log").exists()
        assert not [p for p in temporary.iterdir() if p.name.startswith("wsbuild-log-")]
    assert (ws / "install" / "pc").is_dir()


def _python_with_tests(ws: Path, name: str, passing: bool, depend: tuple[str, ...] = ()) -> None:
    from conftest import write_package

    path = write_package(ws / "src", name, "ament_python", depend)
    (path / "test").mkdir()
    (path / "test" / f"test_{name}.py").write_text(
        f"def test_{name}():\n    assert {passing}\n")


def test_test_abort_on_error_runs_nothing_after_a_failure(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _python_with_tests(ws, "pa", passing=False)
    _python_with_tests(ws, "pb", passing=True, depend=("pa",))
    assert run_wsbuild("build", cwd=ws).returncode == 0
    aborted = run_wsbuild("test", "--abort-on-error", cwd=ws)
    assert aborted.returncode == 1
    assert "1 package not tested: pb" in aborted.stdout
    assert not (ws / "build" / "pb" / "test_results").exists()
    continued = run_wsbuild("test", cwd=ws)
    assert continued.returncode == 1
    assert "1 package passed: pb" in continued.stdout
    assert (ws / "build" / "pb" / "test_results").is_dir()


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args: object) -> None:  # no access log on the test's stderr
        pass


def _self_signed(directory: Path) -> tuple[Path, Path]:
    """A certificate for 127.0.0.1 and its key (openssl, which scripts/setup.sh installs)."""
    cert, key = directory / "cert.pem", directory / "key.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
                    "-subj", "/CN=127.0.0.1", "-addext", "subjectAltName=IP:127.0.0.1",
                    "-keyout", str(key), "-out", str(cert)],
                   check=True, capture_output=True, timeout=60)
    return cert, key


@contextlib.contextmanager
def _serving(directory: Path, tls: tuple[Path, Path] | None = None) -> Iterator[str]:
    """An HTTP (with `tls`: HTTPS) server for `directory` on 127.0.0.1 for the block; its
    base URL."""
    handler = functools.partial(_Quiet, directory=str(directory))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    if tls is not None:
        context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
        context.load_cert_chain(*tls)
        server.socket = context.wrap_socket(server.socket, server_side=True)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"{'https' if tls else 'http'}://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join()


@pytest.mark.parametrize("scheme", ["http", "https"])
def test_mixins_over_http_reach_the_build(make_workspace: Callable[..., Path],
                                          tmp_path: Path, scheme: str) -> None:
    ws = make_workspace({"pc": ("cmake", [])})
    home = tmp_path / "colcon_home"
    env = env_with(home)
    tls = _self_signed(tmp_path) if scheme == "https" else None
    if tls is not None:  # the client trusts the test's certificate, as a company CA would be
        env["SSL_CERT_FILE"] = str(tls[0])
    with _serving(MIXIN_INDEX, tls) as url:
        added = run_wsbuild("mixin", "add", "served", f"{url}/index.yaml", cwd=ws, env=env)
        assert added.returncode == 0, added.stderr
        updated = run_wsbuild("mixin", "update", "served", cwd=ws, env=env)
        assert updated.returncode == 0, updated.stderr
    assert (home / "mixin" / "served" / "build-type.mixin").is_file()
    built = run_wsbuild("build", "--mixin", "release", cwd=ws, env=env)
    assert built.returncode == 0, built.stderr
    assert cache_entry(ws / "build" / "pc", "CMAKE_BUILD_TYPE") == "Release"


def test_colcon_mixin_path_is_searched(make_workspace: Callable[..., Path],
                                       tmp_path: Path) -> None:
    ws = make_workspace({"pc": ("cmake", [])})
    elsewhere = tmp_path / "team_mixins"
    elsewhere.mkdir()
    (elsewhere / "team.mixin").write_text(
        '{"build": {"team-probe": {"cmake-args": ["-DWSBUILD_MIXIN_PROBE=from_path"]}}}\n')
    env = {**env_with(tmp_path / "empty_home"), "COLCON_MIXIN_PATH": str(elsewhere)}
    built = run_wsbuild("build", "--mixin", "team-probe", cwd=ws, env=env)
    assert built.returncode == 0, built.stderr
    assert cache_entry(ws / "build" / "pc", "WSBUILD_MIXIN_PROBE") == "from_path"
    unknown = run_wsbuild("build", "--mixin", "team-probe", cwd=ws, env=env_with(tmp_path / "x"))
    assert unknown.returncode == 2 and "team-probe" in unknown.stderr


class _Hanging:
    """A TCP server on 127.0.0.1 that accepts connections and never answers; notes how long
    each stayed open (accept → the client's close)."""

    def __init__(self) -> None:
        self.socket = socket.create_server(("127.0.0.1", 0))
        self.socket.settimeout(0.1)  # accept() wakes up to see whether the test is over
        self.url = f"http://127.0.0.1:{self.socket.getsockname()[1]}/"
        self.held: list[float] = []
        self._over = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        while not self._over.is_set():
            try:
                conn, _ = self.socket.accept()
            except TimeoutError:
                continue
            conn.settimeout(None)
            threading.Thread(target=self._hold, args=(conn,), daemon=True).start()

    def _hold(self, conn: socket.socket) -> None:
        opened = time.monotonic()
        with conn:
            while conn.recv(4096):
                pass
        self.held.append(time.monotonic() - opened)

    def close(self) -> None:
        self._over.set()
        self._thread.join()
        self.socket.close()


def test_wsbuild_cache_timeout_bounds_a_silent_cache_server(
        make_workspace: Callable[..., Path], tmp_path: Path) -> None:
    ws = make_workspace({"pc": ("cmake", [])})
    server = _Hanging()
    try:
        env = {**os.environ, "WSBUILD_CACHE": server.url, "WSBUILD_CACHE_TIMEOUT": "0.5",
               "XDG_CACHE_HOME": str(tmp_path / "xdg")}
        done = run_wsbuild("build", cwd=ws, env=env)
    finally:
        server.close()
    assert done.returncode == 0, done.stderr
    assert "timed out" in done.stdout + done.stderr
    assert "Finished <<< pc" in done.stdout
    # measured at the server: the client gave up after its 0.5 s, not the default 3 s
    assert server.held and all(0.45 <= held < 3.0 for held in server.held), server.held


def test_the_last_ten_runs_are_kept(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pc": ("cmake", [])})
    runs = []
    for _ in range(12):
        done = run_wsbuild("build", cwd=ws)
        assert done.returncode == 0, done.stderr
        runs.append((ws / "log" / "latest_build").resolve().name)
    assert len(set(runs)) == 12
    kept = sorted(p.name for p in (ws / "log").iterdir()
                  if p.is_dir() and not p.is_symlink() and p.name.startswith("build_"))
    assert kept == sorted(runs[2:])
