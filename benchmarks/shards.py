"""One workspace built by N jobs of a CI matrix through the shared cache (issue 39): the
recording the simulation runs on, and N real `wsbuild build --shard K/N` processes on loopback.

    .venv/bin/python benchmarks/shards.py record     # build the 200-package C++ workspace
                                                     # cold, keep its per-package times in
                                                     # benchmarks/data/shards-200.json (~10 min)
    .venv/bin/python benchmarks/shards.py simulate   # N = 1, 2, 4, 8, 16 on that recording
    .venv/bin/python benchmarks/shards.py loopback   # N = 2 and 3 real shards, one nginx
    .venv/bin/python benchmarks/shards.py all --docs # the three, then docs/benchmarks.md

The simulation (`benchmarks/distribute.py`, `simulate_shards`) splits the recorded packages
with wsbuild's own split (wsbuild/builder/shards/split.py) and plays the shards out as they run:
each machine's workers take its ready packages, the most remaining work first; a package of
another shard is there a transfer after its shard finished it, unless the wait runs out first
(then it is built here).

The loopback runs need N machines where this one has two cores: their packages spend their
build time in a `sleep` (a custom target of a real CMake package, with a real compile and
install around it), so N shards on one machine wait as N machines would work; what is measured
is wsbuild's mechanism (the split, the waits, the restores, the assembly), not the CPU. Each
shard has a workspace of its own seen at one path (tests/one_path.py: a mount namespace each)
and a local cache of its own; they meet in one nginx (tests/nginx_server.py). One machine
building everything is `build --shard 1/1` (it records the times the shards then split by).
"""

from __future__ import annotations

import argparse
import datetime
import json
import random
import shutil
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.tools import (
    DEFAULT_PROJECT_VENV,
    REPO,
    clean_environ,
    cpu_model,
    write_section,
)

DOCS = REPO / "docs" / "benchmarks.md"
DATA = REPO / "benchmarks" / "data"
RECORDING = DATA / "shards-200.json"
LOOPBACK = DATA / "shards-loopback.json"
BEGIN = "<!-- shards.py: begin -->"
END = "<!-- shards.py: end -->"

PACKAGE_XML = """<?xml version="1.0"?>
<package format="3">
  <name>{name}</name>
  <version>0.1.0</version>
  <description>Synthetic package {name}</description>
  <maintainer email="bench@example.com">bench</maintainer>
  <license>Apache-2.0</license>
{depends}  <export>
    <build_type>cmake</build_type>
  </export>
</package>
"""

CMAKELISTS = """cmake_minimum_required(VERSION 3.14)
project({name} CXX)
{find}add_library({name} SHARED {sources})
target_include_directories({name} PUBLIC
  $<BUILD_INTERFACE:${{CMAKE_CURRENT_SOURCE_DIR}}/include> $<INSTALL_INTERFACE:include>)
{link}{extra}install(TARGETS {name} EXPORT {name}Targets LIBRARY DESTINATION lib)
install(EXPORT {name}Targets NAMESPACE {name}:: DESTINATION share/{name}/cmake)
install(DIRECTORY include/ DESTINATION include)
install(FILES {name}Config.cmake DESTINATION share/{name}/cmake)
install(FILES package.xml DESTINATION share/{name})
"""

CONFIG = """include(CMakeFindDependencyMacro)
{find}include(${{CMAKE_CURRENT_LIST_DIR}}/{name}Targets.cmake)
"""

#: a translation unit whose compile time grows with the number of template instances
UNIT = """#include "{name}/{name}.hpp"

#include <algorithm>
#include <map>
#include <string>
#include <vector>

namespace {name}_gen {{
template <int I> struct Item {{ double v[(I % 5) + 1]; int key; }};
template <int I> double work(int n) {{
  std::vector<Item<I>> items(n);
  for (int i = 0; i < n; ++i) items[i].key = (i * 7919 + I) % 101;
  std::sort(items.begin(), items.end(),
            [](const Item<I>& a, const Item<I>& b) {{ return a.key < b.key; }});
  std::map<std::string, Item<I>> by_name;
  for (auto& item : items) by_name[std::to_string(item.key)] = item;
  return static_cast<double>(by_name.size());
}}
}}  // namespace {name}_gen

double {name}_unit{unit}() {{
  double total = 0;
{calls}  return total;
}}
"""


#: the one source of a sleeping package: its time is the sleep, not the compile
SMALL_UNIT = """#include "{name}/{name}.hpp"

double {name}_unit{unit}() {{ return {unit}; }}
"""


@dataclass(frozen=True, slots=True)
class Planned:
    name: str
    depends: tuple[str, ...]
    #: template instances of each source file (compile workspace), or seconds of sleep
    units: tuple[int, ...] = ()
    sleep: float = 0.0


def plan_packages(count: int, *, seed: int, sleeping: bool = False,
                  max_deps: int = 3) -> list[Planned]:
    """`count` packages, each depending on up to `max_deps` earlier ones (recent ones more
    likely: the graph gets depth, as benchmarks/generate.py's); seeded. A compile package has
    1 to 10 source files (most one or two) of 1 to 6 template instances each; a sleeping one
    sleeps 0.5 to 20 s (most 2 to 6)."""
    rng = random.Random(seed)
    planned: list[Planned] = []
    for index in range(count):
        name = f"shard_pkg_{index + 1:03d}"
        chosen: set[int] = set()
        wanted = min(rng.randint(0, max_deps), index)
        while len(chosen) < wanted:
            chosen.add(min(int(index * rng.random() ** 0.5), index - 1))
        depends = tuple(sorted(planned[i].name for i in chosen))
        if sleeping:
            planned.append(Planned(name, depends,
                                   sleep=round(min(20.0, max(0.5, rng.lognormvariate(1.3, 0.6))), 1)))
        else:
            files = min(10, max(1, round(rng.lognormvariate(0.2, 0.8))))
            planned.append(Planned(name, depends,
                                   units=tuple(rng.randint(1, 6) for _ in range(files))))
    return planned


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)


def generate(root: Path, planned: Sequence[Planned]) -> Path:
    """Write the packages under `root`/src (unchanged files keep their times); `root`."""
    for package in planned:
        base = root / "src" / package.name
        name = package.name
        depends = "".join(f"  <depend>{d}</depend>\n" for d in package.depends)
        _write(base / "package.xml", PACKAGE_XML.format(name=name, depends=depends))
        find = "".join(f"find_package({d} REQUIRED)\n" for d in package.depends)
        link = f"target_link_libraries({name} PUBLIC " \
            f"{' '.join(f'{d}::{d}' for d in package.depends)})\n" if package.depends else ""
        units = package.units or (1,)
        sources = " ".join(f"src/unit{i}.cpp" for i in range(len(units)))
        # slow once per fresh build: a target that always runs is never cached
        extra = (f"add_custom_command(OUTPUT slow.stamp COMMAND sleep {package.sleep} "
                 "COMMAND ${CMAKE_COMMAND} -E touch slow.stamp)\n"
                 "add_custom_target(takes_a_while ALL DEPENDS slow.stamp)\n") \
            if package.sleep else ""
        _write(base / "CMakeLists.txt", CMAKELISTS.format(
            name=name, find=find, sources=sources, link=link, extra=extra))
        _write(base / f"{name}Config.cmake", CONFIG.format(
            name=name, find="".join(f"find_dependency({d})\n" for d in package.depends)))
        includes = "".join(f'#include "{d}/{d}.hpp"\n' for d in package.depends)
        declared = "".join(f"double {name}_unit{i}();\n" for i in range(len(units)))
        _write(base / "include" / name / f"{name}.hpp",
               f"#pragma once\n{includes}{declared}")
        for number, instances in enumerate(units):
            calls = "".join(f"  total += {name}_gen::work<{i}>({i + 3});\n"
                            for i in range(instances))
            _write(base / "src" / f"unit{number}.cpp",
                   SMALL_UNIT.format(name=name, unit=number) if package.sleep
                   else UNIT.format(name=name, unit=number, calls=calls))
    return root


# ----------------------------------------------------------------------------- recording

def _stamp() -> str:
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def wsbuild_command(*args: str) -> list[str]:
    return [str(DEFAULT_PROJECT_VENV / "bin" / "python"), "-m", "wsbuild", *args]


def recording_of(workspace: Path, planned: Sequence[Planned], workers: int,
                 command: Sequence[str], *, seed: int, sleeping: bool = False
                 ) -> dict[str, object]:
    """A cold build's per-package times and dependencies, as the simulation reads them: each
    package's seconds from its start to its finish, wsbuild's own time before the first and
    after the last."""
    timings = json.loads((workspace / "log" / "latest_build" / "timings.json").read_text())
    rows = {row["package"]: row for row in timings["packages"]}
    started = min(row["started"] for row in rows.values())
    finished = max(row["finished"] for row in rows.values())
    return {
        "recorded": _stamp(), "command": " ".join(command), "seed": seed,
        "sleeping": sleeping,
        "machine": f"{len(__import__('os').sched_getaffinity(0))} × {cpu_model()}",
        "workers": workers, "wall_seconds": timings["wall_seconds"],
        "cpu_seconds": timings["cpu_seconds"]["total"],
        "before_packages": round(started, 3),
        "after_packages": round(timings["wall_seconds"] - finished, 3),
        "packages": [{"name": p.name, "depends": list(p.depends),
                      "seconds": round(rows[p.name]["finished"] - rows[p.name]["started"], 3)}
                     for p in planned],
    }


def record(work: Path, count: int, seed: int, workers: int) -> dict[str, object]:
    """Build the compile workspace cold (no compiler cache, no build cache) and keep its
    recording in benchmarks/data/."""
    planned = plan_packages(count, seed=seed)
    workspace = work / f"compile{count}"
    for output in ("build", "install", "log"):
        shutil.rmtree(workspace / output, ignore_errors=True)
    generate(workspace, planned)
    command = ["wsbuild", "build", "--no-cache", "--compiler-cache", "none",
               "--parallel-workers", str(workers)]
    env = clean_environ()
    env.pop("WSBUILD_CACHE_DIR", None)
    started = time.monotonic()
    done = subprocess.run(wsbuild_command(*command[1:]), cwd=workspace, env=env,
                          capture_output=True, text=True, timeout=4 * 3600, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"the recorded build failed:\n{done.stdout[-3000:]}{done.stderr[-3000:]}")
    print(f"cold build of {count} packages: {time.monotonic() - started:.0f} s", file=sys.stderr)
    recording = recording_of(workspace, planned, workers, command, seed=seed)
    DATA.mkdir(parents=True, exist_ok=True)
    RECORDING.write_text(json.dumps(recording, indent=1) + "\n")
    return recording


# ----------------------------------------------------------------------------- loopback

#: where every loopback job sees its workspace (each in a mount namespace of its own)
SHARED_PATH = Path("/tmp/wsbuild-bench-shards/ws")


@dataclass(frozen=True, slots=True)
class Job:
    seconds: float
    restored: int
    built: int
    #: packages of other shards built here after their wait ran out
    built_here: int
    output: str


class Loopback:
    """One nginx and the jobs of one CI run at `SHARED_PATH`, each a machine of its own (a
    workspace, a local cache)."""

    def __init__(self, work: Path, template: Path, name: str) -> None:
        sys.path.insert(0, str(REPO / "tests"))
        from nginx_server import NginxServer  # the tests' fixture, reused

        self.home = work / name
        shutil.rmtree(self.home, ignore_errors=True)
        self.template = template
        self.server = NginxServer(self.home / "nginx")
        self.server.start()
        self.run = f"{name}-{time.time_ns()}"

    def close(self) -> None:
        self.server.stop()

    def start(self, machine: str, *args: str) -> tuple[subprocess.Popen[str], float]:
        from one_path import start_at_path

        workspace = self.home / "jobs" / machine
        shutil.copytree(self.template / "src", workspace / "src", symlinks=True)
        env = clean_environ()
        env.update(WSBUILD_CACHE=self.server.url, WSBUILD_SHARD_RUN=self.run,
                   WSBUILD_CACHE_DIR=str(self.home / "machines" / machine))
        log = self.home / f"{machine}.log"
        return start_at_path(workspace, SHARED_PATH, wsbuild_command(*args), env=env,
                             log=log), time.monotonic()

    def finish(self, machine: str, process: subprocess.Popen[str], started: float) -> Job:
        process.wait(timeout=4 * 3600)
        seconds = time.monotonic() - started
        text = (self.home / f"{machine}.log").read_text()
        if process.returncode != 0:
            raise RuntimeError(f"{machine} failed:\n{text[-3000:]}")
        return Job(seconds, text.count("\nRestored <<< ") + text.startswith("Restored <<< "),
                   text.count("\nFinished <<< ") + text.startswith("Finished <<< "),
                   text.count(": building it here ("), text)

    def job(self, machine: str, *args: str) -> Job:
        return self.finish(machine, *self.start(machine, *args))

    def shards(self, count: int, *args: str) -> list[Job]:
        """The N shards at once, as a CI matrix starts them."""
        started = [(f"shard{k}", self.start(f"shard{k}", "build", "--shard", f"{k}/{count}",
                                            *args)) for k in range(1, count + 1)]
        return [self.finish(machine, *process) for machine, process in started]

    def times(self) -> dict[str, object] | None:
        from wsbuild.builder.shards.run import TIMES
        from wsbuild.cache.documents import SharedDocuments
        from wsbuild.cache.settings import CacheSettings

        documents = SharedDocuments.open(CacheSettings(url=self.server.url))
        assert documents is not None
        try:
            return documents.get(TIMES)
        finally:
            documents.close()

    def put_times(self, value: Mapping[str, object]) -> None:
        from wsbuild.builder.shards.run import TIMES
        from wsbuild.cache.documents import SharedDocuments
        from wsbuild.cache.settings import CacheSettings

        documents = SharedDocuments.open(CacheSettings(url=self.server.url))
        assert documents is not None
        try:
            documents.put(TIMES, {"times": value["times"]}, "times", self.home / "scratch")
        finally:
            documents.close()


def loopback(work: Path, count: int, seed: int, workers: int,
             log: callable = print) -> dict[str, object]:  # type: ignore[valid-type]
    """One machine building the sleeping workspace (`build --shard 1/1`: it records the
    times), a fresh clone restoring it all (what an assembling job costs), then N = 2 and 3
    shards and their assembling job, with the times in the cache and, cold, without."""
    planned = plan_packages(count, seed=seed, sleeping=True)
    template = generate(work / "loopback-template", planned)
    SHARED_PATH.parent.mkdir(parents=True, exist_ok=True)
    SHARED_PATH.mkdir(exist_ok=True)
    flags = ("--compiler-cache", "none", "--parallel-workers", str(workers))
    result: dict[str, object] = {"recorded": _stamp(), "packages": count, "seed": seed,
                                 "workers": workers, "path": str(SHARED_PATH)}
    base = Loopback(work, template, "one-machine")
    try:
        one = base.job("machine", "build", "--shard", "1/1", *flags)
        log(f"one machine: {one.seconds:.1f} s")
        times = base.times()
        assert times is not None
        result["recording"] = recording_of(base.home / "jobs" / "machine", planned, workers,
                                           ["wsbuild", "build", "--shard", "1/1", *flags],
                                           seed=seed, sleeping=True)
        assemble = base.job("assemble", "build", *flags)
        assert assemble.restored == count, assemble.output[-2000:]
        log(f"restoring everything: {assemble.seconds:.1f} s")
    finally:
        base.close()
    result["one_machine"] = one.seconds
    result["restore_all"] = assemble.seconds
    runs = []
    for shards in (2, 3):
        for cold in (False, True):
            run = Loopback(work, template, f"n{shards}{'-cold' if cold else ''}")
            try:
                if not cold:
                    run.put_times(times)
                jobs = run.shards(shards, *flags)
                after = run.job("assemble", "build", *flags)
                assert after.restored + after.built == count, after.output[-2000:]
            finally:
                run.close()
            row = {"shards": shards, "cold": cold, "jobs": [job.seconds for job in jobs],
                   "matrix": max(job.seconds for job in jobs), "assemble": after.seconds,
                   "assemble_built": after.built,
                   "built": sum(job.built for job in jobs),
                   "restored": sum(job.restored for job in jobs),
                   "built_here": sum(job.built_here for job in jobs)}
            log(f"N = {shards}{' (cold cache)' if cold else ''}: shards "
                f"{', '.join(f'{j:.1f}' for j in row['jobs'])} s, assembly {after.seconds:.1f} s")
            runs.append(row)
    result["runs"] = runs
    LOOPBACK.parent.mkdir(parents=True, exist_ok=True)
    LOOPBACK.write_text(json.dumps(result, indent=1) + "\n")
    return result


# ----------------------------------------------------------------------------- report

SIMULATED = (1, 2, 4, 8, 16)
#: the targets of issue 39
TARGET_BOUND = 1.15
TARGET_LOOPBACK = 0.20
TARGET_MODEL = 0.10


def estimates(recording: Mapping[str, object]) -> dict[str, float]:
    """What wsbuild estimates for each recorded package with nothing recorded (a cold cache):
    builder/weights.py's, a CMake package's base and each C++ source (a synthetic package's
    sources are its units)."""
    from wsbuild.build_types import get_build_type
    from wsbuild.builder.weights import _ESTIMATE_PER_FILE

    base = get_build_type("cmake").estimate_base
    planned = {p.name: p for p in plan_packages(
        len(recording["packages"]), seed=int(recording.get("seed", 39)),  # type: ignore[arg-type, call-overload]
        sleeping=bool(recording.get("sleeping")))}
    return {name: base + _ESTIMATE_PER_FILE[".cpp"] * len(p.units or (1,))
            for name, p in planned.items()}


def _times(recording: Mapping[str, object], path: Path) -> object:
    from benchmarks.distribute import PackageTimes

    path.write_text(json.dumps(recording))
    return PackageTimes.load(path)


def render(recording: Mapping[str, object], loop: Mapping[str, object] | None,
           scratch: Path | None = None) -> str:
    """The section of docs/benchmarks.md: the simulation on the 200-package recording, then
    the loopback runs against the simulation's prediction for the same N."""
    import tempfile

    from benchmarks.distribute import simulate_shards

    scratch = scratch or Path(tempfile.mkdtemp(prefix="wsbuild-shards-"))
    times = _times(recording, scratch / "recording.json")
    fixed = times.fixed  # type: ignore[attr-defined]
    total = sum(times.seconds.values())  # type: ignore[attr-defined]
    lines = [BEGIN, "", "## One workspace built by N jobs (issue 39)", "",
             f"### Simulation: {len(times.order)} packages, recorded "  # type: ignore[attr-defined]
             f"{recording['recorded']}", "",
             f"`python benchmarks/shards.py record` built the synthetic workspace of "
             f"`benchmarks/shards.py` cold (`{recording['command']}`, no compiler cache, no "
             f"build cache) on {recording['machine']}, shared with other work: "
             f"{recording['wall_seconds']:.0f} s, {total:.0f} s of package time "
             f"({recording['cpu_seconds']:.0f} s CPU). Each package is real C++ (1 to 10 "
             "sources of templates, most one or two) with its dependencies' headers and "
             "libraries; its recorded time is its start to its finish in that build "
             "(`benchmarks/data/shards-200.json`). `benchmarks/distribute.py`'s "
             "`simulate_shards` splits them with wsbuild's split and plays the N jobs out "
             f"({times.workers} workers each, the engine's order, waits and restores as "  # type: ignore[attr-defined]
             "wsbuild runs them, a package of another job there 3 s after it is done).", "",
             "| jobs N | predicted: slowest job | bound max(critical path, total ÷ (N × "
             f"{times.workers})) | ÷ bound | target ≤ {TARGET_BOUND:.2f}× | the split's own "  # type: ignore[attr-defined]
             "prediction | restored from other jobs | built again after a wait |",
             "|---:|---:|---:|---:|---|---:|---:|---:|"]
    rows = {}
    for shards in SIMULATED:
        run = simulate_shards(times, shards)  # type: ignore[arg-type]
        rows[shards] = run
        ratio = run.seconds / run.bound
        lines.append(f"| {shards} | {run.seconds:.1f} s | {run.bound:.1f} s | {ratio:.3f}× | "
                     f"{'✔' if ratio <= TARGET_BOUND else '✘'} | {run.split_predicted:.1f} s "
                     f"| {run.restored} | {run.built_again} |")
    one = rows[1].seconds + fixed
    error = (one - times.wall) / times.wall  # type: ignore[attr-defined]
    cold = simulate_shards(times, 4, split_weights=estimates(recording))  # type: ignore[arg-type]
    lines += ["", f"Critical path {rows[1].critical_path:.1f} s; the one-job prediction plus "
              f"wsbuild's own {fixed:.1f} s is {one:.1f} s against the recorded "
              f"{times.wall:.1f} s ({error:+.1%}, "  # type: ignore[attr-defined]
              f"{'✔' if abs(error) <= TARGET_MODEL else '✘'} within {TARGET_MODEL:.0%}). "
              f"With a cold cache (no recorded times: the split, the order and the waits on "
              f"estimates from the packages' files) 4 jobs are predicted at {cold.seconds:.1f} s "
              f"against {rows[4].seconds:.1f} s, {cold.built_again} packages built again after "
              "a wait ran out."]
    if loop is not None:
        lines += _loopback_lines(loop, scratch)
    lines += ["", END]
    return "\n".join(lines) + "\n"


def _loopback_lines(loop: Mapping[str, object], scratch: Path) -> list[str]:
    from benchmarks.distribute import simulate_shards

    recording = loop["recording"]
    times = _times(recording, scratch / "loopback.json")  # type: ignore[arg-type]
    fixed = times.fixed  # type: ignore[attr-defined]
    restore_all = float(loop["restore_all"])  # type: ignore[arg-type]
    one = float(loop["one_machine"])  # type: ignore[arg-type]
    lines = ["", f"### Loopback: {loop['packages']} packages, N real shards, one nginx "
             f"({loop['recorded']})", "",
             f"`python benchmarks/shards.py loopback`: a workspace of {loop['packages']} CMake "
             "packages whose build spends its time in a `sleep` (0.5 to 20 s) around a real "
             "configure, compile and install, so that N shards on this 2-core machine wait as "
             "N machines would work. Each job is a real `wsbuild build --shard K/N` process "
             "with a workspace of its own at one path (a mount namespace each) and a local "
             "cache of its own; all meet in one nginx (WebDAV) on loopback. One machine is "
             f"`build --shard 1/1` ({one:.1f} s; it records the times); restoring everything "
             f"into a fresh clone takes {restore_all:.1f} s (the assembling job's cost in the "
             "prediction). Predicted = wsbuild's own time "
             f"({fixed:.1f} s) + the simulated slowest job + that restore.", "",
             "| N | times in the cache | jobs (each) | slowest job + assembling job | one "
             "machine | speed-up | predicted | measured ÷ predicted | target ±"
             f"{TARGET_LOOPBACK:.0%} | built again after a wait |",
             "|---:|---|---|---:|---:|---:|---:|---:|---|---:|"]
    for row in loop["runs"]:  # type: ignore[attr-defined]
        shards = row["shards"]
        weights = estimates(recording) if row["cold"] else None  # type: ignore[arg-type]
        run = simulate_shards(times, shards, split_weights=weights)  # type: ignore[arg-type]
        predicted = fixed + run.seconds + restore_all
        measured = row["matrix"] + row["assemble"]
        ratio = measured / predicted
        lines.append(
            f"| {shards} | {'none (cold)' if row['cold'] else 'recorded'} | "
            f"{', '.join(f'{j:.1f}' for j in row['jobs'])} s | {row['matrix']:.1f} + "
            f"{row['assemble']:.1f} = {measured:.1f} s | {one:.1f} s | {one / measured:.2f}× | "
            f"{predicted:.1f} s | {ratio:.2f} | "
            f"{'✔' if abs(ratio - 1) <= TARGET_LOOPBACK else '✘'} | {row['built_here']} |")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/shards.py",
                                     description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=("record", "simulate", "loopback", "all"))
    parser.add_argument("--packages", type=int, default=200)
    parser.add_argument("--loopback-packages", type=int, default=40)
    parser.add_argument("--seed", type=int, default=39)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--work-dir", type=Path,
                        default=Path.home() / ".cache" / "wsbuild-bench" / "shards")
    parser.add_argument("--docs", action="store_true", help="update docs/benchmarks.md")
    args = parser.parse_args(argv)
    work = args.work_dir.resolve()
    work.mkdir(parents=True, exist_ok=True)
    if args.what in ("record", "all"):
        record(work, args.packages, args.seed, args.workers)
    if args.what in ("loopback", "all"):
        loopback(work, args.loopback_packages, args.seed, args.workers,
                 log=lambda text: print(text, file=sys.stderr))
    section = render(json.loads(RECORDING.read_text()),
                     json.loads(LOOPBACK.read_text()) if LOOPBACK.is_file() else None)
    print(section)
    if args.docs:
        write_section(DOCS, BEGIN, END, section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
