"""One workspace built by N jobs of a CI matrix through the shared cache (issue 39): the
recording the simulation runs on, and N real `wsbuild build --shard K/N` processes on loopback.

    .venv/bin/python benchmarks/shards.py record     # build the 200-package C++ workspace
                                                     # cold, keep its per-package times in
                                                     # benchmarks/data/shards-200.json (~10 min)
    .venv/bin/python benchmarks/shards.py simulate   # N = 1, 2, 4, 8, 16 on that recording
    .venv/bin/python benchmarks/shards.py loopback   # N = 2 and 3 real shards, one nginx
    .venv/bin/python benchmarks/shards.py all --docs # the three, then docs/benchmarks.md

The simulation (`benchmarks/distribute.py`, `simulate_shards`) splits the recorded packages
with wsbuild's own split (wsbuild/builder/shards.py) and plays the shards out as they run:
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

from benchmarks.tools import DEFAULT_PROJECT_VENV, REPO, clean_environ, machine_details, write_section

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
        extra = f"add_custom_target(takes_a_while ALL COMMAND sleep {package.sleep})\n" \
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
                            for i in range(instances if not package.sleep else 1))
            _write(base / "src" / f"unit{number}.cpp",
                   UNIT.format(name=name, unit=number, calls=calls))
    return root


# ----------------------------------------------------------------------------- recording

def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "?"


def _stamp() -> str:
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def wsbuild_command(*args: str) -> list[str]:
    return [str(DEFAULT_PROJECT_VENV / "bin" / "python"), "-m", "wsbuild", *args]


def recording_of(workspace: Path, planned: Sequence[Planned], workers: int,
                 command: Sequence[str]) -> dict[str, object]:
    """A cold build's per-package times and dependencies, as the simulation reads them: each
    package's seconds from its start to its finish, wsbuild's own time before the first and
    after the last."""
    timings = json.loads((workspace / "log" / "latest_build" / "timings.json").read_text())
    rows = {row["package"]: row for row in timings["packages"]}
    started = min(row["started"] for row in rows.values())
    finished = max(row["finished"] for row in rows.values())
    return {
        "recorded": _stamp(), "command": " ".join(command),
        "machine": f"{len(__import__('os').sched_getaffinity(0))} × {_cpu_model()}",
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
    recording = recording_of(workspace, planned, workers, command)
    DATA.mkdir(parents=True, exist_ok=True)
    RECORDING.write_text(json.dumps(recording, indent=1) + "\n")
    return recording


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/shards.py",
                                     description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=("record", "simulate", "loopback", "all"))
    parser.add_argument("--packages", type=int, default=200)
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
