"""Failures of the machine are reported as what they are: a full disk, a read-only install base,
`cmake` missing from PATH, a build step killed from outside. Each is one line naming what failed
and what to do, exit code 1 (never 3, "a bug"), and what was installed before stays intact.

The disk is filled and the install base made read-only for real: inside a mount namespace of the
test's own (`unshare`), a small tmpfs or a read-only bind mount covers `install/` and vanishes
with the namespace.
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import pytest

from test_build_helpers import clean_env, output, sh_quote, write, write_ament_python, write_cmake
from wsbuild.errors import environment_failure

pytestmark = pytest.mark.slow

SMALL_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
install(FILES package.xml DESTINATION share/{name})
"""

#: the skip reason when the machine allows no private mount (tests/conftest.py allows it)
NO_MOUNTS = "this machine lets tests mount nothing (needs root or user namespaces)"


def _env() -> dict[str, str]:
    # the build cache would restore packages instead of building them: these tests build
    return clean_env(WSBUILD_CACHE="off")


def _private_mounts(probe: Path) -> list[str]:
    """The command prefix that runs a command in a mount namespace of its own."""
    probe.mkdir(parents=True, exist_ok=True)
    for prefix in (["unshare", "--mount"], ["unshare", "--user", "--map-root-user", "--mount"]):
        try:
            done = subprocess.run(
                [*prefix, "--", "sh", "-c", f"mount -t tmpfs -o size=64k tmpfs {sh_quote(str(probe))}"],
                capture_output=True, text=True, timeout=30, check=False)
        except OSError:
            continue
        if done.returncode == 0:
            return prefix
    pytest.skip(NO_MOUNTS)


def _in_namespace(prefix: list[str], script: str, ws: Path) -> subprocess.CompletedProcess[str]:
    env = _env()
    env["WSBUILD_TEST_PYTHON"] = sys.executable
    return subprocess.run([*prefix, "--", "bash", "-c", script], cwd=ws, env=env,
                          capture_output=True, text=True, timeout=300, check=False)


def _assert_not_a_bug(result: subprocess.CompletedProcess[str]) -> None:
    text = result.stdout + result.stderr
    assert "bug" not in text and "Traceback" not in text, text


def test_a_full_disk_fails_the_package_in_one_line_and_keeps_earlier_installs(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "small", SMALL_CMAKE.format(name="small"))
    big = write_ament_python(ws / "src", "big", modules={})
    (big / "setup.py").write_text((big / "setup.py").read_text().replace(
        "['package.xml']", "['package.xml', 'blob.bin']"))
    (big / "blob.bin").write_bytes(os.urandom(3 * 1024 * 1024))
    (ws / "install").mkdir()
    prefix = _private_mounts(tmp_path / "probe")
    # a 1 MiB disk: small fits, big's 3 MiB data file does not
    result = _in_namespace(prefix, """
        mount -t tmpfs -o size=1m tmpfs install
        "$WSBUILD_TEST_PYTHON" -m wsbuild build --packages-select small || exit 90
        "$WSBUILD_TEST_PYTHON" -m wsbuild build
        echo "exit=$?"
        test -f install/small/share/small/package.xml && echo "small intact"
        test ! -e install/big && echo "big absent"
        . install/setup.sh && echo "AMENT_PREFIX_PATH=$AMENT_PREFIX_PATH"
        """, ws)

    assert result.returncode == 0, output(result)
    lines = result.stdout.splitlines()
    assert "exit=1" in lines, output(result)
    failed = [line for line in lines if line.startswith("Failed")]
    assert len(failed) == 1 and "big" in failed[0], output(result)
    assert "no space left on device while building big" in failed[0]
    assert "free space and build again" in failed[0]
    assert "small intact" in lines and "big absent" in lines
    assert str(ws / "install" / "small") in result.stdout
    _assert_not_a_bug(result)


def test_a_read_only_install_base_is_one_line_not_a_bug(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "small", SMALL_CMAKE.format(name="small"))
    done = subprocess.run([sys.executable, "-m", "wsbuild", "build"], cwd=ws, env=_env(),
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, output(done)
    before = (ws / "install" / "small" / "share" / "small" / "package.xml").read_text()
    # a change, so that the next build must install again
    write(ws / "src" / "small" / "CMakeLists.txt", SMALL_CMAKE.format(name="small") + "# v2\n")
    prefix = _private_mounts(tmp_path / "probe")

    result = _in_namespace(prefix, """
        mount --bind install install && mount -o remount,bind,ro install
        "$WSBUILD_TEST_PYTHON" -m wsbuild build
        """, ws)

    assert result.returncode == 1, output(result)
    assert "read-only file system while building small" in result.stdout, output(result)
    assert "make it writable" in result.stdout
    _assert_not_a_bug(result)
    assert (ws / "install" / "small" / "share" / "small" / "package.xml").read_text() == before


def test_cmake_missing_from_path_names_the_program(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "small", SMALL_CMAKE.format(name="small"))
    empty = tmp_path / "bin"
    empty.mkdir()
    env = _env()
    env["PATH"] = str(empty)  # no cmake (nor anything else) on PATH

    result = subprocess.run([sys.executable, "-m", "wsbuild", "build"], cwd=ws, env=env,
                            capture_output=True, text=True, timeout=300, check=False)

    assert result.returncode == 1, output(result)
    failed = [line for line in result.stdout.splitlines() if line.startswith("Failed")]
    assert "'cmake' is not installed or not on PATH" in failed[0], output(result)
    _assert_not_a_bug(result)
    assert not (ws / "install" / "small").exists()


def test_a_killed_build_step_says_it_was_killed(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "victim", (
        "cmake_minimum_required(VERSION 3.14)\nproject(victim NONE)\n"
        # the configure's parent, cmake itself, is killed, as the OOM killer would
        'execute_process(COMMAND sh -c "kill -9 $PPID")\n'))

    result = subprocess.run([sys.executable, "-m", "wsbuild", "build"], cwd=ws, env=_env(),
                            capture_output=True, text=True, timeout=300, check=False)

    assert result.returncode == 1, output(result)
    failed = [line for line in result.stdout.splitlines() if line.startswith("Failed")]
    assert "'cmake' was killed by SIGKILL" in failed[0], output(result)
    _assert_not_a_bug(result)


def test_which_os_errors_are_the_machines() -> None:
    full = OSError(errno.ENOSPC, "No space left on device", "/src/a", None, "/install/a")
    assert environment_failure(full, doing="building a") == (
        "no space left on device while building a (/install/a): free space and build again")
    missing = FileNotFoundError(errno.ENOENT, "No such file or directory", "cmake")
    assert "'cmake' is not installed or not on PATH" in str(
        environment_failure(missing, doing="building a", program="cmake"))
    # a file wsbuild expected and did not find is no failure of the machine: a bug
    assert environment_failure(FileNotFoundError(errno.ENOENT, "gone", "/x/y"),
                               doing="building a") is None
    assert environment_failure(OSError(errno.EINVAL, "Invalid argument"), doing="x") is None
