"""`wsbuild build --shard K/N` end to end: N real shards, each in a workspace of its own seen at
one path (tests/one_path.py) with a local cache of its own, meeting in one nginx cache; then
the assembling job (a plain `wsbuild build`). Whatever happens to the shards (one dies, the
cache loses an entry, two build the same package, one has another workspace), the assembled
install is byte for byte the one a single machine builds.

The workspace: `base` (a CMake library whose build takes two seconds at least) and four
leaves on it, two CMake libraries and two ament_python packages. The recorded times the
split balances on are written into the cache first (base 2 s, each leaf 10 s), so the split
is known: with two shards, shard 1 builds base, leaf_a and leaf_b, shard 2 leaf_c and leaf_d
and waits for base; with three, shard 1 builds base, leaf_a and leaf_b, shards 2 and 3 one
leaf each. Its waits (builder/shards/split.py) are 13 s: one job building everything is predicted
to take 22 s, and base with a leaf 12 s, and a restore 3 s."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import pytest

from nginx_server import NginxServer, nginx  # noqa: F401 (fixture)
from one_path import run_at_path, start_at_path, stop
from test_cache_build import tree
from test_build_helpers import REQUIRES_ROS, clean_env, output, write_ament_python, write_cmake
from wsbuild.builder.shards.run import TIMES, note_name
from wsbuild.cache.action_result import parse_action_result
from wsbuild.cache.documents import SharedDocuments, document_address
from wsbuild.cache.settings import CacheSettings

pytestmark = [*REQUIRES_ROS, pytest.mark.slow, pytest.mark.xdist_group("one_path_shards")]

BASE = """\
cmake_minimum_required(VERSION 3.14)
project(base CXX)
add_library(base SHARED base.cpp)
# slow once per fresh build (a target that always runs would make the package build every
# time, and no such package is ever cached)
add_custom_command(OUTPUT slow.stamp COMMAND sleep 2 COMMAND ${CMAKE_COMMAND} -E touch slow.stamp)
add_custom_target(takes_a_while ALL DEPENDS slow.stamp)
install(TARGETS base LIBRARY DESTINATION lib)
install(FILES base.hpp DESTINATION include)
"""

LEAF = """\
cmake_minimum_required(VERSION 3.14)
project({name} CXX)
find_path(BASE_INCLUDE base.hpp PATHS ${{CMAKE_PREFIX_PATH}} PATH_SUFFIXES include REQUIRED)
find_library(BASE_LIBRARY base REQUIRED)
add_library({name} SHARED {name}.cpp)
target_include_directories({name} PRIVATE ${{BASE_INCLUDE}})
target_link_libraries({name} ${{BASE_LIBRARY}})
install(TARGETS {name} LIBRARY DESTINATION lib)
"""

PACKAGES = ("base", "leaf_a", "leaf_b", "leaf_c", "leaf_d")
TIMES_RECORDED = {"base": 2.0, "leaf_a": 10.0, "leaf_b": 10.0, "leaf_c": 10.0, "leaf_d": 10.0}
WORKERS = ("--parallel-workers", "2")


def write_template(src: Path) -> None:
    write_cmake(src, "base", BASE, files={"base.cpp": "int base() { return 42; }\n",
                                          "base.hpp": "int base();\n"})
    for name in ("leaf_a", "leaf_c"):
        write_cmake(src, name, LEAF.format(name=name), depend=["base"], files={
            f"{name}.cpp": f'#include "base.hpp"\nint {name}() {{ return base() + 1; }}\n'})
    for name in ("leaf_b", "leaf_d"):
        write_ament_python(src, name, modules={"value.py": f"NAME = {name!r}\n"},
                           depend=["base"])


@dataclass(frozen=True)
class Place:
    """The template's sources, the one path every workspace is seen at, and the install one
    machine builds there."""

    src: Path
    path: Path
    reference: Mapping[str, tuple[str, str, int]]
    root: Path


@pytest.fixture(scope="module")
def place(tmp_path_factory: pytest.TempPathFactory) -> Place:
    root = tmp_path_factory.mktemp("shards")
    src = root / "template" / "src"
    write_template(src)
    path = root / "ws"
    path.mkdir()
    alone = checkout(root / "alone", src)
    env = clean_env(WSBUILD_CACHE="off")
    done = run_at_path(alone, path, [sys.executable, "-m", "wsbuild", "build", *WORKERS],
                       env=env)
    assert done.returncode == 0, output(done)
    return Place(src, path, tree(alone / "install"), root)


def checkout(workspace: Path, src: Path) -> Path:
    shutil.rmtree(workspace, ignore_errors=True)
    shutil.copytree(src, workspace / "src")
    return workspace


@dataclass
class Matrix:
    """One CI run: its jobs' workspaces and machines (local caches) under `home`."""

    place: Place
    home: Path
    server: NginxServer
    run: str

    def env(self, machine: str) -> dict[str, str]:
        """A job's environment; with no run (`run` ""), none a CI system would give."""
        env = clean_env(WSBUILD_CACHE=self.server.url, WSBUILD_SHARD_RUN=self.run,
                        WSBUILD_CACHE_DIR=str(self.home / "machines" / machine))
        if not self.run:
            for variable in ("WSBUILD_SHARD_RUN", "GITHUB_RUN_ID", "CI_PIPELINE_ID"):
                env.pop(variable, None)
        return env

    def workspace(self, name: str, src: Path | None = None) -> Path:
        return checkout(self.home / "jobs" / name, src or self.place.src)

    def start(self, name: str, *args: str, src: Path | None = None) -> subprocess.Popen[str]:
        workspace = self.workspace(name, src)
        return start_at_path(workspace, self.place.path,
                             [sys.executable, "-m", "wsbuild", *args], env=self.env(name))

    def build(self, name: str, *args: str, src: Path | None = None
              ) -> subprocess.CompletedProcess[str]:
        workspace = self.workspace(name, src)
        return run_at_path(workspace, self.place.path,
                           [sys.executable, "-m", "wsbuild", "build", *WORKERS, *args],
                           env=self.env(name))

    def assemble(self, *args: str) -> tuple[subprocess.CompletedProcess[str], Path]:
        """The job after the matrix: a plain build of the whole workspace."""
        done = self.build("assemble", *args)
        assert done.returncode == 0, output(done)
        return done, self.home / "jobs" / "assemble"

    def test(self, name: str, *args: str) -> subprocess.CompletedProcess[str]:
        """`wsbuild test ARGS` in job `name`'s workspace, after its build."""
        return run_at_path(self.home / "jobs" / name, self.place.path,
                           [sys.executable, "-m", "wsbuild", "test", *WORKERS, *args],
                           env=self.env(name))

    def documents(self) -> SharedDocuments:
        documents = SharedDocuments.open(CacheSettings(url=self.server.url))
        assert documents is not None
        return documents

    def note_written(self, shards: int, index: int) -> bool:
        address = document_address(note_name(self.run, shards, index))
        return (self.server.root / "ac" / address).is_file()


@pytest.fixture
def matrix(place: Place, nginx: NginxServer, tmp_path: Path) -> Iterator[Matrix]:
    matrix = Matrix(place, tmp_path, nginx, f"run-{tmp_path.name}")
    documents = matrix.documents()
    assert documents.put(TIMES, {"times": TIMES_RECORDED}, "times", tmp_path)
    documents.close()
    yield matrix


def finished(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith("Finished <<< "))


def restored(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith("Restored <<< "))


def waited_log(workspace: Path, package: str) -> str:
    return (workspace / "log" / "latest_build" / package / "command.log").read_text()


def communicate(process: subprocess.Popen[str]) -> subprocess.CompletedProcess[str]:
    out, _ = process.communicate(timeout=600)
    return subprocess.CompletedProcess(process.args, process.returncode, out, "")


def test_shards_restore_what_the_others_built_and_the_assembled_install_is_one_machines(
        matrix: Matrix) -> None:
    planned = run_at_path(matrix.workspace("plan"), matrix.place.path,
                          [sys.executable, "-m", "wsbuild", "plan", "--shards", "2", "--json",
                           *WORKERS], env=matrix.env("plan"))
    assert planned.returncode == 0, output(planned)
    # the wait for another shard's package is a decision of the plan, and --dry-run says it
    dry = run_at_path(matrix.workspace("two"), matrix.place.path,
                      [sys.executable, "-m", "wsbuild", "build", *WORKERS, "--shard", "2/2",
                       "--dry-run", "--json"], env=matrix.env("two"))
    assert dry.returncode == 0, output(dry)
    waits = {p["name"]: p["wait"] for p in json.loads(dry.stdout)["packages"]}
    assert waits["base"] is not None and waits["base"]["shard"] == "1/2", waits
    assert {name for name, wait in waits.items() if wait is not None} == {"base"}
    first, second = matrix.start("one", "build", *WORKERS, "--shard", "1/2"), \
        matrix.start("two", "build", *WORKERS, "--shard", "2/2")
    one, two = communicate(first), communicate(second)
    assert one.returncode == 0 and two.returncode == 0, output(one) + output(two)
    assert finished(one) == ["base", "leaf_a", "leaf_b"], output(one)
    # shard 2 waited for base, restored it as soon as shard 1 had stored it, built its own
    assert restored(two) == ["base"] and finished(two) == ["leaf_c", "leaf_d"], output(two)
    assert "Waited" in waited_log(matrix.home / "jobs" / "two", "base")
    assert "1 of them restored after waiting" in two.stdout, output(two)
    # the times of what each shard built are in the cache for the next split
    documents = matrix.documents()
    times = documents.get(TIMES)
    assert times is not None and set(times["times"]) == set(PACKAGES)  # type: ignore[arg-type]
    documents.close()
    done, assembled = matrix.assemble()
    assert restored(done) == sorted(PACKAGES) and finished(done) == [], output(done)
    assert tree(assembled / "install") == matrix.place.reference
    # `plan --shards 2` split as the shards did; `test --shard 2/2` takes shard 2's packages
    include = json.loads(planned.stdout)["matrix"]["include"]
    split = json.loads((matrix.home / "jobs" / "two" / "build" / ".wsbuild" / "shard.json")
                       .read_text())
    assert {name: entry["index"] for entry in include for name in entry["packages"]} \
        == split["assignment"] == {"base": 1, "leaf_a": 1, "leaf_b": 1, "leaf_c": 2,
                                   "leaf_d": 2}
    tested = run_at_path(matrix.home / "jobs" / "two", matrix.place.path,
                         [sys.executable, "-m", "wsbuild", "test", "--shard", "2/2"],
                         env=matrix.env("two"))
    assert tested.returncode == 0, output(tested)
    assert "shard 2/2: testing 2 packages of 5, by the split `build --shard` ran here" \
        in tested.stderr, output(tested)


def test_a_shard_that_dies_costs_the_others_a_bounded_wait_and_the_assembly_builds_the_rest(
        matrix: Matrix) -> None:
    dying = matrix.start("one", "build", *WORKERS, "--shard", "1/2")
    deadline = time.monotonic() + 120
    while not matrix.note_written(2, 1) and dying.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.05)
    stop(dying)  # its plan is made, base (two seconds at least) is not stored yet
    two = matrix.build("two", "--shard", "2/2")
    assert two.returncode == 0, output(two)
    assert finished(two) == ["base", "leaf_c", "leaf_d"] and restored(two) == [], output(two)
    assert "base: building it here (shard 1/2 builds it; not in the cache after" in two.stdout
    log = waited_log(matrix.home / "jobs" / "two", "base")
    said = re.search(r"after waiting ([0-9.]+) s", log)
    assert said is not None and float(said.group(1)) <= 13.0, log  # the split's wait, no more
    done, assembled = matrix.assemble()
    assert finished(done) == ["leaf_a", "leaf_b"], output(done)
    assert restored(done) == ["base", "leaf_c", "leaf_d"], output(done)
    assert tree(assembled / "install") == matrix.place.reference


def _archive_of(server: NginxServer, package: str) -> Path:
    """The archive blob of `package`'s entry in the server's cache."""
    for path in server.stored("ac"):
        record = parse_action_result(path.read_bytes())
        if record is not None and record.package == package:
            return server.root / "cas" / record.digest
    raise AssertionError(f"no entry for {package}")


def test_a_cache_that_loses_entries_mid_run_costs_builds_never_the_install(
        matrix: Matrix) -> None:
    one = matrix.build("one", "--shard", "1/2")
    assert one.returncode == 0, output(one)
    _archive_of(matrix.server, "base").unlink()  # evicted: its record is still there
    two = matrix.build("two", "--shard", "2/2")
    assert two.returncode == 0, output(two)
    # the plan found base, its restore could not have the archive: built here
    assert "base" in finished(two) and restored(two) == [], output(two)
    assert "Not restored from the build cache" in waited_log(matrix.home / "jobs" / "two",
                                                              "base")
    _archive_of(matrix.server, "leaf_a").unlink()  # and another one, before the assembly
    done, assembled = matrix.assemble()
    assert finished(done) == ["leaf_a"], output(done)
    assert tree(assembled / "install") == matrix.place.reference


def test_two_shards_that_both_build_a_package_after_their_waits_leave_one_good_install(
        matrix: Matrix) -> None:
    # three shards, the first never starts: the two others both need its base, both wait
    # for it until their waits run out, both build it and store it
    two = matrix.start("two", "build", *WORKERS, "--shard", "2/3")
    three = matrix.start("three", "build", *WORKERS, "--shard", "3/3")
    two_done, three_done = communicate(two), communicate(three)
    for done, leaf in ((two_done, "leaf_c"), (three_done, "leaf_d")):
        assert done.returncode == 0, output(done)
        assert finished(done) == sorted(["base", leaf]), output(done)
        assert "base: building it here (shard 1/3 builds it; not in the cache after" \
            in done.stdout
    done, assembled = matrix.assemble()
    assert restored(done) == ["base", "leaf_c", "leaf_d"], output(done)
    assert finished(done) == ["leaf_a", "leaf_b"], output(done)
    assert tree(assembled / "install") == matrix.place.reference


def test_a_shard_with_another_workspace_is_said_in_one_line_and_never_makes_a_wrong_install(
        matrix: Matrix) -> None:
    one = matrix.build("one", "--shard", "1/2")
    assert one.returncode == 0, output(one)
    other = matrix.home / "other" / "src"
    shutil.copytree(matrix.place.src, other)
    write_cmake(other, "leaf_e", LEAF.format(name="leaf_e"), depend=["base"], files={
        "leaf_e.cpp": '#include "base.hpp"\nint leaf_e() { return base() + 5; }\n'})
    (other / "leaf_c" / "leaf_c.cpp").write_text(
        '#include "base.hpp"\nint leaf_c() { return base() + 3; }\n')
    two = matrix.build("two", "--shard", "2/2", src=other)
    assert two.returncode == 0, output(two)
    said = [line for line in (two.stdout + two.stderr).splitlines()
            if "planned another workspace" in line]
    assert len(said) == 1, output(two)
    assert "shard 1/2 of this run planned another workspace (only here: leaf_e)" in said[0]
    # the assembly (the first workspace) takes only what is of its own sources
    done, assembled = matrix.assemble()
    assert "leaf_c" in finished(done), output(done)
    assert tree(assembled / "install") == matrix.place.reference
    assert not (assembled / "install" / "leaf_e").exists()


def _assignment(matrix: Matrix, job: str) -> dict[str, int]:
    return json.loads((matrix.home / "jobs" / job / "build" / ".wsbuild" / "shard.json")
                      .read_text())["assignment"]


def test_jobs_that_see_different_times_documents_split_alike_and_the_assembly_checks_them(
        matrix: Matrix) -> None:
    """No run id a CI system gives (neither GitHub's, GitLab's nor WSBUILD_SHARD_RUN), and
    job 2 starts after job 1 has published its times: the shared times document job 2 finds
    (base 3 s, leaf_a and leaf_b 1 s each) would split leaf_a and leaf_b off to shard 2 and
    leave leaf_c and leaf_d to no one. Both jobs split on the times fixed for the run (the
    commit's workspace), so every package is built and tested by one of them, and the
    assembling job (`build --assemble 2`) says so."""
    matrix.run = ""
    one = matrix.build("one", "--shard", "1/2")
    assert one.returncode == 0, output(one)
    assert matrix.test("one", "--shard", "1/2").returncode == 0
    documents = matrix.documents()
    assert documents.put(TIMES, {"times": {"base": 3.0, "leaf_a": 1.0, "leaf_b": 1.0,
                                           "leaf_c": 10.0, "leaf_d": 10.0}}, "times",
                         matrix.home)
    documents.close()
    two = matrix.build("two", "--shard", "2/2")
    assert two.returncode == 0, output(two)
    tested = matrix.test("two", "--shard", "2/2")
    assert tested.returncode == 0, output(tested)
    assert _assignment(matrix, "one") == _assignment(matrix, "two") == {
        "base": 1, "leaf_a": 1, "leaf_b": 1, "leaf_c": 2, "leaf_d": 2}
    assert finished(one) == ["base", "leaf_a", "leaf_b"], output(one)
    assert finished(two) == ["leaf_c", "leaf_d"], output(two)
    assert "testing 2 packages of 5" in tested.stderr, output(tested)
    done, assembled = matrix.assemble("--assemble", "2")
    assert restored(done) == sorted(PACKAGES), output(done)
    assert "assembled 5 packages: every one built and tested by one of the 2 shards" \
        in done.stdout, output(done)
    assert tree(assembled / "install") == matrix.place.reference


def test_a_lost_shard_fails_the_assembly_naming_its_packages(matrix: Matrix) -> None:
    """Shard 2 of 2 never ran (its job lost): the assembling job fails, naming the packages
    no shard built and tested, in one line."""
    one = matrix.build("one", "--shard", "1/2")
    assert one.returncode == 0, output(one)
    assert matrix.test("one", "--shard", "1/2").returncode == 0
    done = matrix.build("assemble", "--assemble", "2")
    assert done.returncode == 1, output(done)
    errors = [line for line in done.stderr.splitlines() if line.startswith("wsbuild: error:")]
    assert len(errors) == 1, output(done)
    assert "not built by any shard: leaf_c leaf_d" in errors[0], output(done)
    assert "not tested by any shard: leaf_c leaf_d; shard 2/2 noted no test run" in errors[0]
    assert "Starting >>>" not in done.stdout, output(done)
