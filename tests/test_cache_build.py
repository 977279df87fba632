"""`wsbuild build` with the build cache, end to end against a real nginx (WebDAV): a fresh
clone restores every package byte for byte, poisoned entries and a vanishing server only cost
a rebuild, read-only runs write nothing, and `wsbuild cache stats|prune|verify`."""

from __future__ import annotations

import hashlib
import io
import json
import shutil
import socket
import stat
import subprocess
import sys
import tarfile
import time
from pathlib import Path

import pytest
import zstandard

from nginx_server import NginxServer, nginx  # noqa: F401 (fixture)
from wsbuild.cache.action_result import ActionResult, parse_action_result
from conftest import REPO
from test_build_helpers import (
    REQUIRES_ROS, clean_env, output, sourced, write_ament_python, write_cmake, wsbuild,
)

sys.path.insert(0, str(REPO))
from benchmarks.cache import cache_cost  # noqa: E402  (the benchmark reads cache.log too)

pytestmark = [*REQUIRES_ROS, pytest.mark.slow]

NODE = """\
import rclpy


def main():
    rclpy.init()
    node = rclpy.create_node('cached_talker')
    node.get_logger().info('cached node is up')
    print('talker says hello', flush=True)
    node.destroy_node()
    rclpy.shutdown()
"""

LIB_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(cached_lib CXX)
add_library(cached_lib SHARED lib.cpp)
set_target_properties(cached_lib PROPERTIES VERSION 1.2.0 SOVERSION 1)
install(TARGETS cached_lib LIBRARY DESTINATION lib)
install(FILES package.xml DESTINATION share/cached_lib)
install(PROGRAMS tool.sh DESTINATION bin)
"""

AMENT_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(cached_config NONE)
find_package(ament_cmake REQUIRED)
install(FILES params.yaml DESTINATION share/${PROJECT_NAME}/config)
ament_package()
"""

PACKAGES = ("cached_config", "cached_lib", "cached_talker", "cached_util")


def make_workspace(src: Path) -> None:
    write_cmake(src, "cached_lib", LIB_CMAKE, files={
        "lib.cpp": "int cached_answer() { return 42; }\n",
        "tool.sh": "#!/bin/sh\necho tool\n"})
    (src / "cached_lib" / "tool.sh").chmod(0o755)
    write_cmake(src, "cached_config", AMENT_CMAKE, build_type="ament_cmake",
                buildtool=["ament_cmake"], files={"params.yaml": "rate: 10\n"})
    write_ament_python(src, "cached_util", modules={"util.py": "VALUE = 7\n"},
                       depend=["cached_config"])
    write_ament_python(src, "cached_talker", modules={"talker.py": NODE},
                       scripts={"talker": "cached_talker.talker:main"},
                       depend=["cached_util", "rclpy"])


def tree(root: Path) -> dict[str, tuple[str, str, int]]:
    """Every path below root: kind, content digest or link target, permission bits."""
    result: dict[str, tuple[str, str, int]] = {}
    for path in sorted(root.rglob("*")):
        rel = str(path.relative_to(root))
        mode = stat.S_IMODE(path.lstat().st_mode)
        if path.is_symlink():
            result[rel] = ("link", str(path.readlink()), 0)
        elif path.is_dir():
            result[rel] = ("dir", "", mode)
        else:
            result[rel] = ("file", hashlib.sha256(path.read_bytes()).hexdigest(), mode)
    return result


def env_for(xdg: Path, **extra: str) -> dict[str, str]:
    """A fresh terminal whose local cache lives in `xdg` (WSBUILD_CACHE empty: local only; not
    the suite's cache directory)."""
    env = clean_env(**{"XDG_CACHE_HOME": str(xdg), "WSBUILD_CACHE": "", **extra})
    env.pop("WSBUILD_CACHE_DIR", None)
    # Python writes bytecode, as on most users' machines: running a restored node must not
    # rewrite its installed .pyc (they are checked by the source's hash, not its time)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def restored(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith("Restored <<< "))


def finished(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith("Finished <<< "))


def warnings(result: subprocess.CompletedProcess[str]) -> list[str]:
    return [line for line in result.stdout.splitlines() + result.stderr.splitlines()
            if line.startswith("WARNING:")]


def fresh_clone(ws: Path, template: Path) -> None:
    shutil.rmtree(ws, ignore_errors=True)
    shutil.copytree(template, ws / "src")


def run_build(ws: Path, *args: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    result = wsbuild("build", *args, cwd=ws, env=env)
    assert result.returncode == 0, output(result)
    return result


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    src = tmp_path_factory.mktemp("template") / "src"
    make_workspace(src)
    return src


def test_fresh_clone_restores_every_package_byte_for_byte(tmp_path: Path, template: Path,
                                                          nginx: NginxServer) -> None:
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    first = run_build(ws, "--cache", nginx.url, env=env_for(tmp_path / "machine1"))
    assert finished(first) == sorted(PACKAGES) and warnings(first) == []
    built = tree(ws / "install")
    # each entry: its archive and the package record it was built with, found under its key,
    # under its variant (the digests of the variables its steps read) and by the list of its
    # key's variants
    assert len(nginx.stored("ac")) == 3 * len(PACKAGES) == 3 * len(nginx.stored("cas")) // 2
    # what the cache cost this cold build is in its log, in the form benchmarks/cache.py reads
    log = (ws / "log" / "latest_build" / "cache.log").read_text()
    assert f"{len(PACKAGES)} missed" in log and f"{len(PACKAGES)} stored" in log, log
    cost = cache_cost(ws)
    assert cost.build_threads > 0 and cost.cache_thread_cpu > 0, log

    # another machine, same checkout path: everything comes from the server
    fresh_clone(ws, template)
    second = run_build(ws, "--cache", nginx.url, env=env_for(tmp_path / "machine2"))
    assert restored(second) == sorted(PACKAGES), output(second)
    assert finished(second) == [] and warnings(second) == []
    assert f"{len(PACKAGES)} packages restored from cache" in second.stdout
    assert tree(ws / "install") == built
    assert not any(line.startswith("PUT") for line in nginx.requests()[-2 * len(PACKAGES):])

    ran = sourced(ws, "install/cached_talker/lib/cached_talker/talker\n"
                      "install/cached_lib/bin/tool.sh\n"
                      "python3 -c 'import cached_util.util as u; print(\"util\", u.VALUE)'\n")
    assert "talker says hello" in ran.stdout and "tool" in ran.stdout and "util 7" in ran.stdout
    assert "cached node is up" in ran.stderr + ran.stdout

    # what was restored is recorded as built: the next build has nothing to do
    third = run_build(ws, env=env_for(tmp_path / "machine2"))
    assert finished(third) == [] and restored(third) == []
    assert f"{len(PACKAGES)} packages up to date" in third.stdout

    # the same machine after `rm -rf build install`: the local cache, no network at all
    shutil.rmtree(ws / "build")
    shutil.rmtree(ws / "install")
    requests = len(nginx.requests())
    fourth = run_build(ws, "--cache", nginx.url, env=env_for(tmp_path / "machine2"))
    assert restored(fourth) == sorted(PACKAGES)
    assert len(nginx.requests()) == requests
    assert tree(ws / "install") == built


def test_a_restore_records_no_build_time_for_the_next_estimate(tmp_path: Path,
                                                               template: Path) -> None:
    """The status line estimates a build from the recorded build times: a restore (a
    fraction of a second) is no build time, so a clean checkout that restored everything
    records none, and the time a build took stays recorded across a restore."""
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    run_build(ws, env=env_for(tmp_path / "m1"))
    durations = ws / "build" / ".wsbuild" / "durations.json"
    built = json.loads(durations.read_text())
    assert set(built) == set(PACKAGES)
    shutil.rmtree(ws / "install")
    restored_run = run_build(ws, env=env_for(tmp_path / "m1"))
    assert sorted(restored(restored_run)) == sorted(PACKAGES), output(restored_run)
    assert json.loads(durations.read_text()) == built
    for base in ("build", "install", "log"):
        shutil.rmtree(ws / base)
    run_build(ws, env=env_for(tmp_path / "m1"))
    assert not durations.exists()


def test_switching_back_restores_instead_of_rebuilding(tmp_path: Path, template: Path) -> None:
    env = env_for(tmp_path / "xdg")
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    run_build(ws, env=env)
    module = ws / "src" / "cached_util" / "cached_util" / "util.py"
    module.write_text("VALUE = 8\n")  # another branch
    other = run_build(ws, env=env)
    # cached_talker's build reads nothing of cached_util: cut off, not rebuilt
    assert finished(other) == ["cached_util"]
    module.write_text("VALUE = 7\n")  # and back
    back = run_build(ws, env=env)
    assert restored(back) == ["cached_util"] and finished(back) == []
    installed = sorted((ws / "install" / "cached_util").rglob("util.py"))
    assert installed and installed[0].read_text() == "VALUE = 7\n"


def test_a_checkout_at_another_path_misses(tmp_path: Path, template: Path) -> None:
    """Installed files embed the absolute prefix (CMake configs, setup scripts, shebangs):
    an entry made for one path would be wrong at another, so the path is in the key."""
    env = env_for(tmp_path / "xdg")
    first = tmp_path / "one"
    fresh_clone(first, template)
    run_build(first, env=env)
    second = tmp_path / "two"
    fresh_clone(second, template)
    result = run_build(second, env=env)
    assert restored(result) == [] and finished(result) == sorted(PACKAGES)
    assert str(first) not in (second / "install" / "cached_talker" / "lib" / "cached_talker"
                              / "talker").read_text()


def test_poisoned_remote_entry_is_refused_and_rebuilt(tmp_path: Path, template: Path,
                                                      nginx: NginxServer) -> None:
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    run_build(ws, "--cache", nginx.url, env=env_for(tmp_path / "m1"))
    built = tree(ws / "install")
    # one archive replaced by another package's (a valid archive under the wrong digest), one
    # record pointing to an archive that writes outside its prefix (under its true digest)
    archives = {record.digest for p in nginx.stored("ac")
                if (record := parse_action_result(p.read_bytes())) is not None}
    blobs = [blob for blob in nginx.stored("cas") if blob.name in archives]
    blobs[0].write_bytes(blobs[1].read_bytes())
    raw = io.BytesIO()
    with tarfile.open(fileobj=raw, mode="w") as tar:
        info = tarfile.TarInfo("../../escaped.txt")
        info.size = 5
        tar.addfile(info, io.BytesIO(b"owned"))
    evil = zstandard.ZstdCompressor().compress(raw.getvalue())
    evil_digest = hashlib.sha256(evil).hexdigest()
    (nginx.root / "cas" / evil_digest).write_bytes(evil)
    # every address of another package's entry (its key's and its variant's)
    entries = [(p, record) for p in nginx.stored("ac")
               if (record := parse_action_result(p.read_bytes())) is not None]
    victim = next(record.package for p, record in entries if record.digest != blobs[0].name)
    for path, record in entries:
        if record.package == victim:
            path.write_bytes(ActionResult(record.package, evil_digest, len(evil),
                                          record.record_digest, record.record_size).encode())

    fresh_clone(ws, template)
    result = run_build(ws, "--cache", nginx.url, env=env_for(tmp_path / "m2"))
    refused = [w for w in warnings(result) if "refused" in w]
    assert len(refused) == 2 and len(warnings(result)) == 2, output(result)
    assert len(finished(result)) == 2 and len(restored(result)) == len(PACKAGES) - 2
    assert tree(ws / "install") == built
    assert not list(tmp_path.rglob("escaped.txt"))


def test_a_server_whose_entries_no_wsbuild_can_use_is_named_once_with_their_count(
        tmp_path: Path, template: Path, nginx: NginxServer) -> None:
    """Every key the server has answers with a well-formed record and a digest-correct archive
    in no format wsbuild writes (a plain tar whose member climbs out of the install), with no
    package record: each is refused before anything is unpacked, the install is a build's,
    and one warning names the server and how many entries it refused."""
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    run_build(ws, "--cache", nginx.url, env=env_for(tmp_path / "m1"))
    built = tree(ws / "install")
    raw = io.BytesIO()
    with tarfile.open(fileobj=raw, mode="w") as tar:
        info = tarfile.TarInfo("../../escaped.txt")
        info.size = 5
        tar.addfile(info, io.BytesIO(b"owned"))
    evil = raw.getvalue()
    evil_digest = hashlib.sha256(evil).hexdigest()
    (nginx.root / "cas" / evil_digest).write_bytes(evil)
    # the action results (a key's variants documents, beside them, stay as they are)
    entries = [path for path in nginx.stored("ac")
               if parse_action_result(path.read_bytes()) is not None]
    for path in entries:
        record = parse_action_result(path.read_bytes())
        assert record is not None
        path.write_bytes(ActionResult(record.package, evil_digest, len(evil)).encode())

    fresh_clone(ws, template)
    result = run_build(ws, "--cache", nginx.url, env=env_for(tmp_path / "m2"))
    assert warnings(result) == [
        f"WARNING: cache server {nginx.url.rstrip('/')} answered {len(PACKAGES)} entries "
        "wsbuild cannot use "
        "(no package record of these inputs: not a wsbuild cache, or it serves something else "
        "at these addresses); they were refused before anything was unpacked, and built "
        "here"], output(result)
    # one refusal per package looked up (a key and its variant's key each hold a result)
    assert len(entries) >= len(PACKAGES) and len(finished(result)) == len(PACKAGES)
    assert tree(ws / "install") == built
    assert not list(tmp_path.rglob("escaped.txt"))


def test_unreachable_server_costs_one_warning_and_builds_normally(tmp_path: Path,
                                                                  template: Path) -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    result = run_build(ws, "--cache", f"http://user:secret@127.0.0.1:{port}/",
                       env=env_for(tmp_path / "xdg"))
    assert finished(result) == sorted(PACKAGES)
    assert len(warnings(result)) == 1 and "off for this run" in warnings(result)[0]
    assert "secret" not in result.stdout + result.stderr


def test_server_stopped_mid_run(tmp_path: Path, template: Path, nginx: NginxServer) -> None:
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    process = subprocess.Popen(
        [sys.executable, "-m", "wsbuild", "build", "--cache", nginx.url,
         "--parallel-workers", "1"],
        cwd=ws, env=env_for(tmp_path / "xdg"), stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 120
        while not nginx.requests() and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        nginx.stop()
        out, _ = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 0, out
    assert len([line for line in out.splitlines() if line.startswith("WARNING:")]) <= 1, out
    assert "Summary: 4 packages finished" in out
    assert (ws / "install" / "cached_talker" / "lib" / "cached_talker" / "talker").exists()


def test_read_only_restores_but_writes_nothing(tmp_path: Path, template: Path,
                                               nginx: NginxServer) -> None:
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    run_build(ws, "--cache", nginx.url, env=env_for(tmp_path / "trusted"))
    stored = nginx.stored("ac") + nginx.stored("cas")
    # nginx logs a request after answering it: wait until every stored file's PUT is logged
    puts = len(nginx.requests(at_least=len(stored), method="PUT"))

    fresh_clone(ws, template)
    (ws / "src" / "cached_util" / "cached_util" / "util.py").write_text("VALUE = 8\n")
    untrusted = tmp_path / "untrusted"
    result = run_build(ws, "--cache", nginx.url, "--cache-read-only", env=env_for(untrusted))
    assert restored(result) == ["cached_config", "cached_lib"]
    assert finished(result) == ["cached_talker", "cached_util"]
    assert nginx.stored("ac") + nginx.stored("cas") == stored
    assert sum(line.startswith("PUT") for line in nginx.requests()) == puts
    assert not (untrusted / "wsbuild" / "ac").exists() or not any((untrusted / "wsbuild" / "ac").iterdir())


def test_no_cache_touches_no_cache(tmp_path: Path, template: Path, nginx: NginxServer) -> None:
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    run_build(ws, "--cache", nginx.url, "--no-cache", env=env_for(tmp_path / "xdg"))
    assert nginx.requests() == [] and not (tmp_path / "xdg" / "wsbuild").exists()
    off = run_build(ws, "--force", env=env_for(tmp_path / "xdg2", WSBUILD_CACHE="off"))
    assert finished(off) == sorted(PACKAGES) and not (tmp_path / "xdg2" / "wsbuild").exists()


def test_concurrent_builds_share_one_local_cache(tmp_path: Path, template: Path) -> None:
    env = env_for(tmp_path / "xdg")
    workspaces = [tmp_path / "a", tmp_path / "b"]
    for ws in workspaces:
        fresh_clone(ws, template)
    processes = [subprocess.Popen([sys.executable, "-m", "wsbuild", "build"], cwd=ws, env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
                 for ws in workspaces]
    outs = [p.communicate(timeout=300)[0] for p in processes]
    assert [p.returncode for p in processes] == [0, 0], outs
    check = wsbuild("cache", "verify", cwd=tmp_path, env=env)
    assert check.returncode == 0, output(check)
    assert f"{2 * len(PACKAGES)} entries" in check.stdout
    for ws in workspaces:
        shutil.rmtree(ws / "install")
        shutil.rmtree(ws / "build")
        again = run_build(ws, env=env)
        assert restored(again) == sorted(PACKAGES), (
            output(again) + (ws / "log" / "latest_build" / "cache.log").read_text())


def test_merged_install_restores_the_same_tree(tmp_path: Path, template: Path) -> None:
    env = env_for(tmp_path / "xdg")
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    run_build(ws, "--merge-install", env=env)
    built = tree(ws / "install")
    shutil.rmtree(ws / "build")
    shutil.rmtree(ws / "install")
    again = run_build(ws, "--merge-install", env=env)
    assert restored(again) == sorted(PACKAGES)
    assert tree(ws / "install") == built
    sourced(ws, "python3 -c 'import cached_util.util'\n")


def test_cache_verb_stats_verify_prune(tmp_path: Path, template: Path) -> None:
    env = env_for(tmp_path / "xdg")
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    run_build(ws, env=env)
    stats = wsbuild("cache", "stats", cwd=tmp_path, env=env)
    assert stats.returncode == 0, output(stats)
    # each entry: its archive and the package record it was built with
    assert f"{len(PACKAGES)} entries, {2 * len(PACKAGES)} blobs" in stats.stdout
    assert str(tmp_path / "xdg" / "wsbuild") in stats.stdout

    blob = sorted((tmp_path / "xdg" / "wsbuild" / "cas").iterdir())[0]
    blob.write_bytes(b"rotten")
    verify = wsbuild("cache", "verify", cwd=tmp_path, env=env)
    assert verify.returncode == 1, output(verify)
    assert f"cas/{blob.name}: content does not match its digest" in verify.stdout
    assert wsbuild("cache", "verify", cwd=tmp_path, env=env).returncode == 0

    prune = wsbuild("cache", "prune", "--max-size", "0", cwd=tmp_path, env=env)
    assert prune.returncode == 0, output(prune)
    assert "0 entries, 0 blobs" in wsbuild("cache", "stats", cwd=tmp_path, env=env).stdout


TESTED_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(tested CXX)
enable_testing()
add_executable(check check.cpp)
add_test(NAME answer COMMAND check)
install(TARGETS check DESTINATION bin)
install(FILES package.xml DESTINATION share/tested)
"""


def test_a_restored_package_whose_tests_run_from_its_build_tree_is_built_for_them(
        tmp_path: Path) -> None:
    """A restore brings back a package's install, not the build directory CTest runs its tests
    from: `wsbuild test` builds that tree first (with the options the record holds), then
    tests what was built; a restored package without tests there is tested as it is."""
    env = env_for(tmp_path / "xdg")
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "tested", TESTED_CMAKE,
                files={"check.cpp": "int main() { return 0; }\n"})
    run_build(ws, "--cmake-args", "-DCMAKE_BUILD_TYPE=Release", env=env)
    for base in ("build", "install"):
        shutil.rmtree(ws / base)
    again = run_build(ws, "--cmake-args", "-DCMAKE_BUILD_TYPE=Release", env=env)
    assert restored(again) == ["tested"], output(again)

    tested = wsbuild("test", cwd=ws, env=env)

    assert tested.returncode == 0, output(tested)
    assert "building tested for its tests first" in tested.stdout, output(tested)
    assert "1 test, 0 errors, 0 failures" in tested.stdout, output(tested)
    cache = (ws / "build" / "tested" / "CMakeCache.txt").read_text()
    assert "CMAKE_BUILD_TYPE:UNINITIALIZED=Release" in cache or \
        "CMAKE_BUILD_TYPE:STRING=Release" in cache
    # built with the options it was built with: the next build has nothing to do
    after = run_build(ws, "--cmake-args", "-DCMAKE_BUILD_TYPE=Release", env=env)
    assert "1 package up to date" in after.stdout, output(after)


def test_another_install_base_of_the_same_checkout_builds_rather_than_restores(
        tmp_path: Path, template: Path) -> None:
    """The cache key holds the install prefix: an install names its prefix (CMake's configs,
    scripts' interpreters, the environment hooks), so the same sources, at the same path,
    installed into another base are built for it, not restored from the first base's
    entries (a checkout at another path differs in its sources' path too: the test above)."""
    env = env_for(tmp_path / "xdg")
    ws = tmp_path / "ws"
    fresh_clone(ws, template)
    assert finished(run_build(ws, env=env)) == sorted(PACKAGES)
    shutil.rmtree(ws / "build")
    again = run_build(ws, "--install-base", "install_other", env=env)
    assert restored(again) == [] and finished(again) == sorted(PACKAGES), output(again)
    talker = (ws / "install_other" / "cached_talker" / "lib" / "cached_talker" / "talker")
    assert str(ws / "install" / "") not in talker.read_text()
