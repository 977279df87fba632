""""Up to date" and "restored" are never wrong, in wsbuild's default configuration (the local
build cache on, the no-op replay on): after a recorded no-op, one change at a time — to a file
outside the package that its build system read (a header, a CMake include, a depfile's input, a
glob's directory, an installed directory, a data_files file), to a file reached through a
symlink, to a file in a directory named build, install or log or in a vendored subdirectory
marked COLCON_IGNORE, to an environment variable a CMakeLists.txt or setup.py reads, to what a
subprocess searched (pkg-config), to a file whose time was set back — and the next build
rebuilds what it must (never restoring an entry built from the old input), its install equal to
a build from scratch. Secrets in the environment never reach a file; a symlink loop, a
read-only workspace and a lock deleted under a waiting build are handled as the full run
handles them. Every build here runs its steps under the build-step oracle
(builder/oracles/step_trace.py): what they read must be in the package's record."""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from test_build_helpers import clean_env, output, sh_quote, write, write_ament_python, write_cmake
from test_build_helpers import wsbuild as run

from wsbuild.engine.recording import WHY_NOT

#: a recording run must start this long after the last change it could read (the racy rule)
SETTLE = 1.1
#: every build step of this module's builds runs under strace, checked against the record
pytestmark = pytest.mark.usefixtures("traced_steps")
RECORD = Path("build") / ".wsbuild" / "noop" / "build.json"


def _env(**extra: str) -> dict[str, str]:
    """A fresh terminal, in wsbuild's default configuration (the local build cache on)."""
    return clean_env(**extra)


def _build(ws: Path, *args: str, env: dict[str, str] | None = None
           ) -> subprocess.CompletedProcess[str]:
    result = run("build", *args, cwd=ws, env=env or _env())
    assert result.returncode == 0, output(result)
    assert "Traceback" not in result.stdout + result.stderr, output(result)
    return result


def _recorded_noop(ws: Path, env: dict[str, str] | None = None) -> None:
    """Build, then a no-op that leaves its record (what the next build replays). A no-op
    leaves none when a path it looked at changed in the second before it started or while it
    ran (the racy rule of engine/recording.py); the full suite on a loaded machine met that
    once in four runs here, so a second no-op may be needed, and it must leave one."""
    _build(ws, env=env)
    for _attempt in range(2):
        time.sleep(SETTLE)
        result = _build(ws, env=env)
        assert "0 packages finished" in result.stdout, output(result)
        if (ws / RECORD).is_file():
            break
    why = ws / RECORD.parent / WHY_NOT
    assert (ws / RECORD).is_file(), \
        f"two no-ops in a row left no record: {why.read_text() if why.is_file() else ''}"


def _rebuilt(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith("Finished <<<"))


def _tree(root: Path) -> dict[str, str]:
    tree = {}
    for path in sorted(root.rglob("*")):
        rel = str(path.relative_to(root))
        if path.is_symlink():
            tree[rel] = "-> " + os.readlink(path)
        elif path.is_file():
            tree[rel] = hashlib.sha256(path.read_bytes()).hexdigest()
    return tree


def _assert_install_as_from_scratch(ws: Path) -> None:
    """install/ equals what a build from scratch of the same sources makes (--no-cache: the
    build cache would restore what the incremental build stored)."""
    incremental = _tree(ws / "install")
    for base in ("build", "install", "log"):
        shutil.rmtree(ws / base)
    _build(ws, "--no-cache")
    assert _tree(ws / "install") == incremental


def _program(ws: Path, pkg: str) -> str:
    done = subprocess.run([str(ws / "install" / pkg / "bin" / pkg)], capture_output=True,
                          text=True, timeout=30, check=True)
    return done.stdout.strip()


def _cmake_program(src: Path, name: str, prelude: str, source: str, *,
                   files: dict[str, str] | None = None) -> Path:
    return write_cmake(src, name, f"""
        cmake_minimum_required(VERSION 3.16)
        project({name} CXX)
        {prelude}
        add_executable({name} src/main.cpp)
        install(TARGETS {name} DESTINATION bin)
        install(FILES package.xml DESTINATION share/{name})
        """, files={"src/main.cpp": source, **(files or {})})


def _same_size_edit(path: Path, old: str, new: str, *, keep_time: bool = False) -> None:
    assert len(old) == len(new)
    before = path.stat()
    path.write_text(path.read_text().replace(old, new))
    if keep_time:  # as `cp -p`, `touch -d` or a sync tool leave it
        os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))


def test_a_cmake_file_included_from_outside_the_package_rebuilds_it(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    shared = write(ws / "cmake" / "greeting.cmake", 'set(GREETING "one")\n')
    _cmake_program(ws / "src", "greeter",
                   f'include("{shared}")\nadd_compile_definitions(GREETING="${{GREETING}}")',
                   '#include <cstdio>\nint main() { std::puts(GREETING); return 0; }\n')
    _recorded_noop(ws)
    assert _program(ws, "greeter") == "one"

    _same_size_edit(shared, '"one"', '"two"')
    result = _build(ws)

    assert _rebuilt(result) == ["greeter"], output(result)
    assert _program(ws, "greeter") == "two"
    dry = run("build", "--dry-run", cwd=ws, env=_env())
    assert "greeter" in dry.stdout and "up to date" in dry.stdout, output(dry)
    _assert_install_as_from_scratch(ws)


def test_a_header_outside_the_package_rebuilds_it(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    header = write(ws / "third_party" / "include" / "answer.h", "#define ANSWER 41\n")
    _cmake_program(ws / "src", "asker", f'include_directories("{header.parent}")',
                   '#include <cstdio>\n#include "answer.h"\n'
                   'int main() { std::printf("%d\\n", ANSWER); return 0; }\n')
    _recorded_noop(ws)

    _same_size_edit(header, "41", "42")
    result = _build(ws)

    assert _rebuilt(result) == ["asker"], output(result)
    assert _program(ws, "asker") == "42"
    _assert_install_as_from_scratch(ws)


def test_a_same_size_edit_with_its_time_set_back_rebuilds(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    pkg = _cmake_program(ws / "src", "clock", "",
                         '#include <cstdio>\nint main() { std::puts("tick"); return 0; }\n')
    _recorded_noop(ws)

    _same_size_edit(pkg / "src" / "main.cpp", '"tick"', '"tock"', keep_time=True)
    result = _build(ws)

    assert _rebuilt(result) == ["clock"], output(result)
    assert _program(ws, "clock") == "tock"  # Ninja, which compares times, was told too
    _assert_install_as_from_scratch(ws)


def test_a_source_file_linked_from_outside_the_workspace_rebuilds(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    outside = write(tmp_path / "elsewhere" / "main.cpp",
                    '#include <cstdio>\nint main() { std::puts("left"); return 0; }\n')
    pkg = _cmake_program(ws / "src", "linked", "", "")
    (pkg / "src" / "main.cpp").unlink()
    (pkg / "src" / "main.cpp").symlink_to(outside)
    _recorded_noop(ws)

    _same_size_edit(outside, '"left"', '"rite"')
    result = _build(ws)

    assert _rebuilt(result) == ["linked"], output(result)
    assert _program(ws, "linked") == "rite"
    _assert_install_as_from_scratch(ws)


def test_a_dangling_package_link_that_gains_a_target_is_a_new_package(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _cmake_program(ws / "src", "first", "",
                   '#include <cstdio>\nint main() { std::puts("first"); return 0; }\n')
    later = tmp_path / "checkouts" / "later"
    (ws / "src" / "later").symlink_to(later)  # not there yet
    _recorded_noop(ws)

    _cmake_program(later.parent, "later", "",
                   '#include <cstdio>\nint main() { std::puts("later"); return 0; }\n')
    result = _build(ws)

    assert _rebuilt(result) == ["later"], output(result)
    assert _program(ws, "later") == "later"


def test_a_symlink_loop_in_place_of_a_recorded_directory_builds(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    pkg = _cmake_program(ws / "src", "loopy", "",
                         '#include <cstdio>\nint main() { std::puts("ok"); return 0; }\n',
                         files={"data/notes.txt": "notes\n"})
    _recorded_noop(ws)

    shutil.rmtree(pkg / "data")
    (pkg / "data").symlink_to(pkg / "data")  # a link to itself: ELOOP
    result = run("build", cwd=ws, env=_env())

    assert result.returncode == 0, output(result)
    assert "Traceback" not in result.stdout + result.stderr, output(result)
    assert _rebuilt(result) == ["loopy"], output(result)
    assert _program(ws, "loopy") == "ok"


def test_a_pkg_config_module_installed_in_the_default_directory_resolves(
        tmp_path: Path) -> None:
    """pkg-config searches its compiled-in path even when PKG_CONFIG_PATH names nothing: a
    module installed there is seen by `info`, the dependency check and its memo."""
    name = f"wsbprobe{uuid.uuid4().hex[:8]}"
    default = subprocess.run(["pkg-config", "--variable", "pc_path", "pkg-config"],
                             capture_output=True, text=True, check=True).stdout.strip()
    directory = Path(default.split(":")[0])  # /usr/local/lib/<triplet>/pkgconfig
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "needs_probe", "cmake_minimum_required(VERSION 3.16)\n"
                "project(needs_probe NONE)\ninstall(FILES package.xml DESTINATION share)\n",
                depend=[name])
    env = _env()
    env.pop("PKG_CONFIG_PATH", None)
    env.pop("PKG_CONFIG_LIBDIR", None)
    _recorded_noop(ws, env)
    time.sleep(SETTLE)
    before = run("info", "needs_probe", cwd=ws, env=env)
    assert before.returncode == 0 and "unresolved" in before.stdout, output(before)
    refused = run("build", "--strict-dependencies", cwd=ws, env=env)
    assert refused.returncode == 2, output(refused)

    made = not directory.exists()
    pc = directory / f"{name}.pc"
    try:
        directory.mkdir(parents=True, exist_ok=True)
        pc.write_text(f"Name: {name}\nDescription: a probe\nVersion: 1.2.3\n")
        info = run("info", "needs_probe", cwd=ws, env=env)
        strict = run("build", "--strict-dependencies", cwd=ws, env=env)
    finally:
        pc.unlink()
        if made:
            directory.rmdir()

    assert info.returncode == 0, output(info)
    line = next(line for line in info.stdout.splitlines() if name in line)
    assert "unresolved" not in line and "pkg-config" in line, output(info)
    assert strict.returncode == 0, output(strict)


SECRETS = {
    "WSBUILD_CACHE_TOKEN": "wsb-token-" + uuid.uuid4().hex,
    "AWS_SECRET_ACCESS_KEY": "aws-secret-" + uuid.uuid4().hex,
    "GITHUB_TOKEN": "ghp_" + uuid.uuid4().hex,
}


def test_no_secret_of_the_environment_is_written_and_records_are_private(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _cmake_program(ws / "src", "quiet", "",
                   '#include <cstdio>\nint main() { std::puts("ok"); return 0; }\n')
    env = _env(**SECRETS)
    _build(ws, env=env)
    for _ in range(2):  # no-ops, which leave the replay's record (and then replay it)
        time.sleep(SETTLE)
        assert "0 packages finished" in _build(ws, env=env).stdout
    run("list", cwd=ws, env=env)
    time.sleep(SETTLE)
    run("list", cwd=ws, env=env)

    for base in ("build", "log", "install"):
        for path in (ws / base).rglob("*"):
            if path.is_file() and not path.is_symlink():
                data = path.read_bytes()
                for name, value in SECRETS.items():
                    assert value.encode() not in data, f"{name}'s value is in {path}"
    own = ws / "build" / ".wsbuild"
    assert own.stat().st_mode & 0o777 == 0o700
    # the package's record (digests of the environment) and the replay's records, as far as
    # the no-ops left them (tests/test_noop_replay.py holds that they do)
    records = [ws / "build" / "quiet" / ".wsbuild" / "record.json",
               *((own / "noop").iterdir() if (own / "noop").is_dir() else ())]
    assert records[0].is_file()
    assert (ws / "build" / "quiet" / ".wsbuild").stat().st_mode & 0o777 == 0o700
    for record in records:
        assert record.stat().st_mode & 0o777 == 0o600, record
    assert (ws / "build" / ".wsbuild.build.lock").stat().st_mode & 0o077 == 0


def _private_mounts(probe: Path) -> list[str]:
    probe.mkdir(parents=True, exist_ok=True)
    for prefix in (["unshare", "--mount"], ["unshare", "--user", "--map-root-user", "--mount"]):
        done = subprocess.run([*prefix, "--", "sh", "-c",
                               f"mount -t tmpfs -o size=64k tmpfs {sh_quote(str(probe))}"],
                              capture_output=True, text=True, timeout=30, check=False)
        if done.returncode == 0:
            return prefix
    pytest.fail("this machine lets tests mount nothing (needs root or user namespaces), "
                "which CI has")


def test_a_read_only_workspace_is_one_line_on_the_replayed_path_too(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _cmake_program(ws / "src", "frozen", "",
                   '#include <cstdio>\nint main() { std::puts("ok"); return 0; }\n')
    _recorded_noop(ws)
    prefix = _private_mounts(tmp_path / "probe")
    env = _env(WSBUILD_TEST_PYTHON=sys.executable)
    result = subprocess.run(
        [*prefix, "--", "bash", "-c",
         'mount --bind . . && mount -o remount,bind,ro . && cd "$PWD" '
         '&& "$WSBUILD_TEST_PYTHON" -m wsbuild build'],
        cwd=ws, env=env, capture_output=True, text=True, timeout=300, check=False)

    text = result.stdout + result.stderr
    assert result.returncode == 1, output(result)  # as the full run: the machine's failure
    assert "Traceback" not in text and "bug" not in text, output(result)
    errors = [line for line in text.splitlines() if line.startswith("wsbuild: error")]
    assert len(errors) == 1 and "read-only" in errors[0], output(result)


SLOW_CONFIGURE = """
cmake_minimum_required(VERSION 3.16)
project(slow NONE)
file(APPEND "{marker}" "start\\n")
execute_process(COMMAND sleep 2)
file(APPEND "{marker}" "end\\n")
install(FILES package.xml DESTINATION share/slow)
"""


def _wait_for(predicate, what: str, timeout: float = 60) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def test_a_build_waiting_on_a_deleted_lock_never_runs_beside_another(tmp_path: Path) -> None:
    """`wsbuild clean` deletes build/ (the lock file with it) while it holds the lock; a build
    that was waiting then must wait for the build that took the new lock file."""
    ws = tmp_path / "ws"
    marker = tmp_path / "configures.log"
    write_cmake(ws / "src", "slow", SLOW_CONFIGURE.format(marker=marker))
    (ws / "build").mkdir(parents=True)
    lock_path = ws / "build" / ".wsbuild.build.lock"
    held = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o600)
    fcntl.flock(held, fcntl.LOCK_EX)
    waiting_log = tmp_path / "waiting.log"
    env = _env()
    with open(waiting_log, "w") as out:
        waiting = subprocess.Popen([sys.executable, "-m", "wsbuild", "build"], cwd=ws,
                                   env=env, stdout=out, stderr=subprocess.STDOUT)
    try:
        _wait_for(lambda: "waiting for it to finish" in waiting_log.read_text(),
                  "the build to wait")
        shutil.rmtree(ws / "build")  # what clean does, holding the lock
        later = subprocess.Popen([sys.executable, "-m", "wsbuild", "build"], cwd=ws, env=env,
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        _wait_for(lambda: marker.exists() and "start" in marker.read_text(),
                  "the later build to configure")
        os.close(held)  # the old lock is free: the waiting build takes it
        held = -1
        later_out, _ = later.communicate(timeout=300)
        assert later.wait() == 0, later_out
        assert waiting.wait(timeout=300) == 0, waiting_log.read_text()
    finally:
        if held >= 0:
            os.close(held)
        for process in (waiting,):
            if process.poll() is None:
                process.kill()
                process.wait()

    lines = marker.read_text().split()
    assert lines[:2] == ["start", "end"], f"two builds configured at once: {lines}"


def test_a_compiler_flag_in_the_environment_rebuilds_from_a_fresh_configure(
        tmp_path: Path) -> None:
    """CXXFLAGS is read by CMake at the first configure only: a change rebuilds the package
    from a fresh configure (colcon would keep the cached flags); its value is in no record."""
    ws = tmp_path / "ws"
    _cmake_program(ws / "src", "tagged", "",
                   '#include <cstdio>\n#ifndef TAG\n#define TAG "plain"\n#endif\n'
                   'int main() { std::puts(TAG); return 0; }\n')
    _recorded_noop(ws)
    assert _program(ws, "tagged") == "plain"

    flagged = _env(CXXFLAGS='-DTAG=\\"flagged-by-env\\"')
    result = _build(ws, env=flagged)

    assert _rebuilt(result) == ["tagged"], output(result)
    assert "CXXFLAGS changed since" in result.stdout + result.stderr, output(result)
    assert _program(ws, "tagged") == "flagged-by-env"
    assert "0 packages finished" in _build(ws, env=flagged).stdout
    for path in (ws / "build" / "tagged" / ".wsbuild").rglob("*.json"):
        assert "flagged-by-env" not in path.read_text(), path
    dry = run("build", "--dry-run", cwd=ws, env=_env())
    assert "environment variable changed: CXXFLAGS" in dry.stdout, output(dry)


# ------------------------------------------------------- one record per package (issue 36)


def _restored(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith("Restored <<<"))


def test_an_outside_header_changed_is_built_not_restored_and_watched_after_a_restore(
        tmp_path: Path) -> None:
    """The build cache holds an entry built from the old header: it is not restored (the
    entry's record names the header, whose content differs here). After `rm -rf build
    install` the entry of the current header is restored, and its record watches the header
    as a build's does, with the cache on or off."""
    ws = tmp_path / "ws"
    header = write(ws / "third_party" / "include" / "answer.h", "#define ANSWER 41\n")
    _cmake_program(ws / "src", "asker", f'include_directories("{header.parent}")',
                   '#include <cstdio>\n#include "answer.h"\n'
                   'int main() { std::printf("%d\\n", ANSWER); return 0; }\n')
    _recorded_noop(ws)
    _same_size_edit(header, "41", "42")
    changed = _build(ws)
    assert _rebuilt(changed) == ["asker"] and _restored(changed) == [], output(changed)
    assert _program(ws, "asker") == "42"

    for base in ("build", "install"):
        shutil.rmtree(ws / base)
    restored = _build(ws)
    assert _restored(restored) == ["asker"], output(restored)
    assert _program(ws, "asker") == "42"
    _same_size_edit(header, "42", "43")
    dry = run("build", "--dry-run", cwd=ws, env=_env())
    assert f"file outside the package changed: {header}" in dry.stdout, output(dry)
    assert _rebuilt(_build(ws, "--no-cache")) == ["asker"]
    assert _program(ws, "asker") == "43"
    _assert_install_as_from_scratch(ws)


def test_a_data_files_file_outside_the_python_package_is_built_not_restored(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    shared = write(ws / "shared" / "params.yaml", "rate: 10\n")
    pkg = write_ament_python(ws / "src", "talker", modules={"main.py": "def main():\n    pass\n"})
    setup = (pkg / "setup.py").read_text()
    (pkg / "setup.py").write_text(setup.replace(
        "data_files=[", "data_files=[\n        ('share/talker/config', ['../../shared/params.yaml']),"))
    _recorded_noop(ws)
    installed = ws / "install" / "talker" / "share" / "talker" / "config" / "params.yaml"
    assert installed.read_text() == "rate: 10\n"

    _same_size_edit(shared, "10", "20")
    result = _build(ws)

    assert _rebuilt(result) == ["talker"] and _restored(result) == [], output(result)
    assert installed.read_text() == "rate: 20\n"
    _assert_install_as_from_scratch(ws)


@pytest.mark.parametrize("where", ["talker/log/levels.py", "talker/build/parts.py",
                                   "talker/install/steps.py"])
def test_a_python_subpackage_named_log_build_or_install_is_part_of_the_package(
        tmp_path: Path, where: str) -> None:
    """A directory named log, build or install inside a package is the package's (only the
    workspace's own bases are not)."""
    ws = tmp_path / "ws"
    pkg = write_ament_python(ws / "src", "talker", modules={"main.py": "def main():\n    pass\n"})
    sub = pkg / Path(where).parent
    write(sub / "__init__.py", "")
    write(pkg / where, "LEVEL = 1\n")  # setup.py's find_packages() finds the subpackage
    _recorded_noop(ws)
    installed = next((ws / "install" / "talker").rglob(where))

    _same_size_edit(pkg / where, "1", "2")
    result = _build(ws)

    assert _rebuilt(result) == ["talker"], output(result)
    assert installed.read_text() == "LEVEL = 2\n"


def test_a_vendored_subdirectory_marked_colcon_ignore_is_part_of_the_package(
        tmp_path: Path) -> None:
    """COLCON_IGNORE keeps the crawl out of a vendored copy, not the package's CMakeLists.txt,
    which builds it with add_subdirectory."""
    ws = tmp_path / "ws"
    pkg = _cmake_program(ws / "src", "bundled", "add_subdirectory(vendor)",
                         '#include <cstdio>\nint vendored();\n'
                         'int main() { std::printf("%d\\n", vendored()); return 0; }\n',
                         files={"vendor/COLCON_IGNORE": "",
                                "vendor/CMakeLists.txt": "add_library(vendored STATIC v.cpp)\n",
                                "vendor/v.cpp": "int vendored() { return 1; }\n"})
    (pkg / "CMakeLists.txt").write_text((pkg / "CMakeLists.txt").read_text().replace(
        "install(TARGETS", "target_link_libraries(bundled vendored)\ninstall(TARGETS"))
    _recorded_noop(ws)
    assert _program(ws, "bundled") == "1"

    _same_size_edit(pkg / "vendor" / "v.cpp", "1", "2")
    result = _build(ws)

    assert _rebuilt(result) == ["bundled"], output(result)
    assert _program(ws, "bundled") == "2"


def test_a_file_added_to_an_outside_glob_directory_is_installed(tmp_path: Path) -> None:
    """`file(GLOB … CONFIGURE_DEPENDS)` over a directory outside the package: Ninja globs again
    before each build; a new file there rebuilds and installs it."""
    ws = tmp_path / "ws"
    write(ws / "maps" / "a.yaml", "a\n")
    _cmake_program(ws / "src", "mapper",
                   'file(GLOB MAPS CONFIGURE_DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/../../maps/*.yaml")\n'
                   "install(FILES ${MAPS} DESTINATION share/mapper/maps)",
                   '#include <cstdio>\nint main() { std::puts("map"); return 0; }\n')
    _recorded_noop(ws)

    write(ws / "maps" / "b.yaml", "b\n")
    result = _build(ws)

    assert _rebuilt(result) == ["mapper"], output(result)
    assert sorted(p.name for p in (ws / "install" / "mapper" / "share" / "mapper" / "maps")
                  .iterdir()) == ["a.yaml", "b.yaml"]
    _assert_install_as_from_scratch(ws)


def test_an_outside_directory_installed_with_install_directory_is_installed_anew(
        tmp_path: Path) -> None:
    """`install(DIRECTORY …)` and `install(FILES …)` from outside the package: the install
    script names the sources, which colcon's install step reads every time."""
    ws = tmp_path / "ws"
    write(ws / "assets" / "meshes" / "arm.stl", "solid arm\n")
    write(ws / "assets" / "robot.urdf", "<robot name='one'/>\n")
    _cmake_program(ws / "src", "describe",
                   'install(DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}/../../assets/meshes/" '
                   "DESTINATION share/describe/meshes)\n"
                   'install(FILES "${CMAKE_CURRENT_SOURCE_DIR}/../../assets/robot.urdf" '
                   "DESTINATION share/describe)",
                   '#include <cstdio>\nint main() { std::puts("robot"); return 0; }\n')
    _recorded_noop(ws)
    share = ws / "install" / "describe" / "share" / "describe"

    write(ws / "assets" / "meshes" / "hand.stl", "solid hand\n")
    assert _rebuilt(_build(ws)) == ["describe"]
    assert (share / "meshes" / "hand.stl").is_file()
    _same_size_edit(ws / "assets" / "robot.urdf", "one", "two")
    assert _rebuilt(_build(ws)) == ["describe"]
    assert "two" in (share / "robot.urdf").read_text()
    _assert_install_as_from_scratch(ws)


@pytest.mark.parametrize("reader", ["cmake", "setup.py"])
def test_an_environment_variable_the_build_reads_rebuilds_with_its_new_value(
        tmp_path: Path, reader: str) -> None:
    """TURTLEBOT3_MODEL, read by a CMakeLists.txt at configure or by a setup.py: the record
    holds every variable (by digest), the build configures again, the install has the new
    value, and `--dry-run` names the variable."""
    ws = tmp_path / "ws"
    if reader == "cmake":
        _cmake_program(ws / "src", "bot",
                       'add_compile_definitions(MODEL="$ENV{TURTLEBOT3_MODEL}")',
                       '#include <cstdio>\nint main() { std::puts(MODEL); return 0; }\n')
    else:
        pkg = write_ament_python(ws / "src", "bot", modules={"main.py": "def main():\n    pass\n"})
        setup = (pkg / "setup.py").read_text()
        (pkg / "setup.py").write_text(setup.replace(
            "version='0.1.0'", "version='0.1.0' if os.environ.get('TURTLEBOT3_MODEL') == "
            "'burger' else '0.2.0'"))
    burger, waffle = _env(TURTLEBOT3_MODEL="burger"), _env(TURTLEBOT3_MODEL="waffle")
    _recorded_noop(ws, burger)
    dry = run("build", "--dry-run", cwd=ws, env=waffle)
    assert "environment variable changed: TURTLEBOT3_MODEL" in dry.stdout, output(dry)

    result = _build(ws, env=waffle)

    assert _rebuilt(result) == ["bot"], output(result)
    if reader == "cmake":
        assert _program(ws, "bot") == "waffle"
    else:
        assert list((ws / "install" / "bot").rglob("bot-0.2.0-*.egg-info")), output(result)
    back = _build(ws, env=burger)  # the first build's entry, proved again
    assert _restored(back) == ["bot"], output(back)
    if reader == "cmake":
        assert _program(ws, "bot") == "burger"


def test_sourcing_the_workspace_rebuilds_nothing_and_a_test_run_changes_no_source(
        tmp_path: Path) -> None:
    """What `source install/setup.bash` adds to the environment is the workspace's own
    install, no input; `wsbuild test` writes __pycache__ and .pytest_cache beside the sources,
    which the record leaves out by its one rule."""
    ws = tmp_path / "ws"
    pkg = write_ament_python(ws / "src", "checked", modules={"main.py": "def main():\n    pass\n"})
    write(pkg / "test" / "test_main.py", "import checked.main\n\n\ndef test_it():\n"
          "    assert checked.main.main() is None\n")
    _build(ws)
    sourced = subprocess.run(["bash", "-c", "source install/setup.bash && env -0"], cwd=ws,
                             env=_env(), capture_output=True, text=True, check=True)
    env = dict(item.split("=", 1) for item in sourced.stdout.split("\0") if "=" in item)
    assert str(ws / "install") in env.get("AMENT_PREFIX_PATH", "")
    tested = run("test", cwd=ws, env=env, timeout=600)
    assert tested.returncode == 0, output(tested)
    write(pkg / "__pycache__" / "stale.cpython-311.pyc", "bytecode")
    write(pkg / ".pytest_cache" / "v" / "cache" / "lastfailed", "{}")
    again = _build(ws, env=env)
    assert "0 packages finished" in again.stdout, output(again)


LIBRARY = """
cmake_minimum_required(VERSION 3.16)
project(greeting CXX)
add_library(greeting SHARED src/greeting.cpp)
target_include_directories(greeting PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                           $<INSTALL_INTERFACE:include>)
install(TARGETS greeting EXPORT greetingTargets LIBRARY DESTINATION lib)
install(DIRECTORY include/ DESTINATION include)
install(EXPORT greetingTargets DESTINATION share/greeting/cmake)
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/greetingConfig.cmake
     "include(\\${CMAKE_CURRENT_LIST_DIR}/greetingTargets.cmake)\\n")
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/greetingConfig.cmake DESTINATION share/greeting/cmake)
"""


@pytest.mark.parametrize("edit", ["library", "header installed in the second of the last build"])
def test_the_build_after_a_dependency_was_rebuilt_is_a_no_op(tmp_path: Path, edit: str) -> None:
    """A dependency's rebuild rebuilds its user, once: the next build is a no-op. wsbuild sets
    an installed file's modification time forward only when its time is not after the user's
    last build (CMake installs a header with its source's time cut to the second: one edited
    in the second the user last built looks older than its objects; here the user's last
    build is dated a second later instead); a time wsbuild set is its own, not a change the
    user's build may have missed."""
    ws = tmp_path / "ws"
    lib = write_cmake(ws / "src", "greeting", LIBRARY, files={
        "include/greeting.h": "#define GREETING_WORD \"hello\"\nconst char *greeting();\n",
        "src/greeting.cpp": '#include "greeting.h"\nconst char *greeting() { return "one"; }\n'})
    _cmake_program(ws / "src", "greeter", "find_package(greeting REQUIRED)\n"
                   "link_libraries(greeting)\nset(CMAKE_INSTALL_RPATH_USE_LINK_PATH TRUE)",
                   '#include <cstdio>\n#include "greeting.h"\n'
                   'int main() { std::printf("%s %s\\n", GREETING_WORD, greeting()); }\n',
                   files={"package.xml": ""})
    write(ws / "src" / "greeter" / "package.xml", (ws / "src" / "greeting" / "package.xml")
          .read_text().replace("greeting", "greeter").replace(
              "</package>", "  <depend>greeting</depend>\n</package>"))
    _recorded_noop(ws)
    assert _program(ws, "greeter") == "hello one"

    if edit == "library":
        _same_size_edit(lib / "src" / "greeting.cpp", '"one"', '"two"')
    else:
        _same_size_edit(lib / "include" / "greeting.h", '"hello"', '"howdy"')
        record = ws / "build" / "greeter" / ".wsbuild" / "record.json"
        later = time.time_ns() + 1_000_000_000
        os.utime(record, ns=(later, later))
    result = _build(ws)
    assert _rebuilt(result) == ["greeter", "greeting"], output(result)
    assert _program(ws, "greeter") == ("hello two" if edit == "library" else "howdy one")

    time.sleep(SETTLE)
    again = _build(ws)
    assert "0 packages finished" in again.stdout, output(again)
    dry = run("build", "--dry-run", cwd=ws, env=_env())
    assert "changed" not in dry.stdout, output(dry)
