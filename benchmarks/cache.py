"""The shared build cache against colcon: a fresh clone restored from a warm cache (remote:
nginx with WebDAV on loopback; local: ~/.cache/wsbuild) versus colcon's full build, and what
the cache costs a cold build (packing and uploading every package).

    .venv/bin/python benchmarks/cache.py                      # mixed 36-package workspace
    .venv/bin/python benchmarks/cache.py --scenarios mixed compile_heavy
    .venv/bin/python benchmarks/cache.py --quick              # smoke run

A "fresh clone" is the workspace directory removed and its src/ copied back from a pristine
template at the same path (the cache key includes the absolute install prefix). Each cold
or warm-remote run gets a new, empty local cache directory (XDG_CACHE_HOME).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.generate import GeneratedWorkspace, WorkspaceSpec, generate_workspace
from benchmarks.measure import CommandFailed, Measurement, run_timed
from benchmarks.tools import (
    DEFAULT_COLCON_VENV, DEFAULT_PROJECT_VENV, REPO, Log, SetupError, Tools, ensure_colcon_venv,
    machine_details, make_tools,
)

sys.path.insert(0, str(REPO / "tests"))
from nginx_server import NginxServer  # noqa: E402  (the tests' nginx fixture, reused)

SCENARIOS = ("mixed", "compile_heavy")


@dataclass(slots=True)
class Result:
    scenario: str
    packages: int
    runs: dict[str, Measurement] = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)
    #: per cold build with the cache: seconds its workers spent in the cache (log/*/cache.log)
    cache_seconds: list[float] = field(default_factory=list)


def _cache_seconds(ws: Path) -> float:
    """Lookups, storing and the final wait for packing and uploads of the last build, from the
    line wsbuild writes to log/latest_build/cache.log: the time the build's own threads spent
    in the cache (thread-seconds: an upper bound of the wall time they added). Packing and
    uploading on the cache's thread overlap the build and are not counted."""
    import re

    text = (ws / "log" / "latest_build" / "cache.log").read_text().split(";")[0]
    return sum(float(v) for v in re.findall(r"(\d+\.\d+) s", text))


def _tree_digest(root: Path) -> str:
    """Paths, link targets and file contents below root (what 'byte-identical' compares)."""
    digest = hashlib.sha256()
    for dirpath, dirnames, filenames in sorted(os.walk(root)):
        dirnames.sort()
        for name in sorted(filenames + [d for d in dirnames if os.path.islink(os.path.join(dirpath, d))]):
            path = os.path.join(dirpath, name)
            rel = os.path.relpath(path, root)
            if os.path.islink(path):
                digest.update(f"L {rel} {os.readlink(path)}\n".encode())
            elif rel.endswith(".pyc"):
                digest.update(f"F {rel}\n".encode())  # byte-compiled at install: same source
            else:
                with open(path, "rb") as handle:
                    digest.update(f"F {rel} ".encode() + hashlib.sha256(handle.read()).digest())
    return digest.hexdigest()


class CacheBench:
    def __init__(self, tools: Tools, work_dir: Path, log: Log, repeats: int,
                 colcon_repeats: int) -> None:
        self.tools = tools
        self.work_dir = work_dir
        self.log = log
        self.repeats = repeats
        self.colcon_repeats = colcon_repeats
        self.log_file = work_dir / "bench-cache.log"
        self._xdg = 0

    def fresh_xdg(self) -> Path:
        self._xdg += 1
        path = self.work_dir / "xdg" / str(self._xdg)
        shutil.rmtree(path, ignore_errors=True)
        path.mkdir(parents=True)
        return path

    def clone(self, template: Path, ws: Path) -> None:
        shutil.rmtree(ws, ignore_errors=True)
        shutil.copytree(template / "src", ws / "src", symlinks=True)

    def wsbuild(self, ws: Path, *args: str, xdg: Path | None, cache: str) -> list[str]:
        env = dict(self.tools.wsbuild_env)
        env["WSBUILD_CACHE"] = cache
        if xdg is not None:
            env["XDG_CACHE_HOME"] = str(xdg)
        sample = run_timed(self.tools.wsbuild_cmd("build", *args), cwd=ws, env=env,
                           log_file=self.log_file)
        self._last = sample
        return sample.output.splitlines()

    def scenario(self, name: str, make: Callable[[Path], GeneratedWorkspace]) -> Result:
        template_ws = make(self.work_dir / f"{name}-template")
        total = len(template_ws.packages)
        result = Result(name, total)
        ws = self.work_dir / f"{name}-wsbuild"
        colcon_ws = self.work_dir / f"{name}-colcon"

        self.log(f"{name}: colcon full build x{self.colcon_repeats}")
        m = Measurement()
        for _ in range(self.colcon_repeats):
            self.clone(template_ws.root, colcon_ws)
            m.samples.append(run_timed(self.tools.colcon_cmd("build"), cwd=colcon_ws,
                                       env=self.tools.colcon_env, log_file=self.log_file))
        result.runs["colcon full build"] = m

        nginx = NginxServer(self.work_dir / "nginx")
        shutil.rmtree(nginx.home, ignore_errors=True)
        nginx.home.mkdir(parents=True)
        nginx.start()
        try:
            self._wsbuild_runs(result, template_ws.root, ws, nginx, total)
        finally:
            nginx.stop()
        return result

    def _wsbuild_runs(self, result: Result, template: Path, ws: Path, nginx: NginxServer,
                      total: int) -> None:
        runs = result.runs
        for key in ("cold, no cache", "cold, filling local + remote cache",
                    "fresh clone, warm remote cache", "fresh clone, warm local cache"):
            runs[key] = Measurement()
        built_digest = ""
        warm_local: Path | None = None
        self.log(f"{result.scenario}: wsbuild cold builds x{self.repeats} (alternating "
                 "without and with the cache)")
        for _ in range(self.repeats):
            self.clone(template, ws)
            self.wsbuild(ws, xdg=self.fresh_xdg(), cache="off")
            runs["cold, no cache"].samples.append(self._last)
            built_digest = _tree_digest(ws / "install")
            self.clone(template, ws)
            shutil.rmtree(nginx.root, ignore_errors=True)
            nginx.root.mkdir()
            warm_local = self.fresh_xdg()
            self.wsbuild(ws, xdg=warm_local, cache=nginx.url)
            runs["cold, filling local + remote cache"].samples.append(self._last)
            result.cache_seconds.append(_cache_seconds(ws))
        cas = len(list((nginx.root / "cas").iterdir())) if (nginx.root / "cas").exists() else 0
        if cas != total:
            result.problems.append(f"remote cache holds {cas} archives for {total} packages")

        self.log(f"{result.scenario}: fresh clone, warm remote cache x{self.repeats}")
        for _ in range(self.repeats):
            self.clone(template, ws)
            out = self.wsbuild(ws, xdg=self.fresh_xdg(), cache=nginx.url)
            runs["fresh clone, warm remote cache"].samples.append(self._last)
            self._check(result, ws, out, total, built_digest, "warm remote")

        self.log(f"{result.scenario}: fresh clone, warm local cache x{self.repeats}")
        for _ in range(self.repeats):
            self.clone(template, ws)
            out = self.wsbuild(ws, xdg=warm_local, cache="")
            runs["fresh clone, warm local cache"].samples.append(self._last)
            self._check(result, ws, out, total, built_digest, "warm local")

    def _check(self, result: Result, ws: Path, out: list[str], total: int, built: str,
               label: str) -> None:
        restored = sum(1 for line in out if line.startswith("Restored <<< "))
        if restored != total:
            result.problems.append(f"{label}: {restored} of {total} packages restored")
        if _tree_digest(ws / "install") != built:
            result.problems.append(f"{label}: install/ differs from the one built without cache")


def render(results: Sequence[Result], details: dict[str, str], command: str,
           started: str) -> str:
    lines = [f"### Shared build cache ({started})", "",
             f"`{command}` — {details.get('CPUs')} CPUs ({details.get('CPU model')}), "
             f"{details.get('wsbuild')}, colcon: {details.get('colcon')}. Medians; "
             "CPU load of other processes during each run in the log.", ""]
    for r in results:
        colcon = r.runs["colcon full build"]
        cold = r.runs["cold, no cache"]
        filling = r.runs["cold, filling local + remote cache"]
        lines += [f"**{r.scenario}** ({r.packages} packages)", "",
                  "| run | median | best | runs (share of the CPUs other processes took) "
                  "| vs colcon: medians | bests | target |",
                  "|---|---:|---:|---|---:|---:|---|"]
        for key, m in r.runs.items():
            ratio = colcon.median / m.median if m.median else 0
            best = colcon.best / m.best if m.best else 0
            target = ""
            if key.startswith("fresh clone"):
                target = "≥ 20× ✔" if ratio >= 20 else "≥ 20× **✘**"
            runs = ", ".join(f"{s.seconds:.2f} ({s.contention:.0%})" for s in m.samples)
            versus = "– | –" if key.startswith("colcon") else f"{ratio:.1f}× | {best:.1f}×"
            lines.append(f"| {key} | {m.median:.2f} s | {m.best:.2f} s | {runs} | {versus} "
                         f"| {target} |")
        overhead = (filling.median - cold.median) / cold.median * 100
        spent = statistics.median(r.cache_seconds) if r.cache_seconds else 0.0
        share = spent / filling.median * 100
        lines += ["", f"Cost of the cache on a cold build (lookups, packing, storing, waiting "
                  f"for uploads at the end), measured inside wsbuild: {spent:.2f} s of "
                  f"{filling.median:.2f} s = {share:.1f} % (target ≤ 5 %: "
                  f"{'✔' if share <= 5 else '✘'}). Wall-clock difference of the medians above: "
                  f"{overhead:+.1f} % (runs alternate; other processes' load moves it).", ""]
        if r.problems:
            lines += ["Checks: " + "; ".join(r.problems), ""]
        else:
            lines += ["Checks: every package restored in every warm run; install/ identical "
                      "(paths, links, contents) to the one built without the cache.", ""]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/cache.py", description=__doc__)
    parser.add_argument("--quick", action="store_true", help="8 packages, one repeat each")
    parser.add_argument("--scenarios", nargs="+", choices=SCENARIOS, default=["mixed"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--colcon-repeats", type=int, default=2)
    parser.add_argument("--project-venv", type=Path, default=DEFAULT_PROJECT_VENV)
    parser.add_argument("--colcon-venv", type=Path, default=DEFAULT_COLCON_VENV)
    parser.add_argument("--work-dir", type=Path,
                        default=Path.home() / ".cache" / "wsbuild-bench" / "cache")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the raw numbers")
    args = parser.parse_args(argv)
    log = Log()
    try:
        ensure_colcon_venv(args.colcon_venv, args.project_venv, log)
    except SetupError as exc:
        print(f"benchmark setup failed: {exc}", file=sys.stderr)
        return 2
    tools = make_tools(args.project_venv.resolve(), args.colcon_venv.resolve())
    details = machine_details(tools)
    work = args.work_dir.resolve()
    work.mkdir(parents=True, exist_ok=True)
    repeats = 1 if args.quick else args.repeats
    bench = CacheBench(tools, work, log, repeats, 1 if args.quick else args.colcon_repeats)
    bench.log_file.write_text("")
    log(f"every command's output: {bench.log_file}")
    started = time.strftime("%Y-%m-%d %H:%M %Z")
    makers: dict[str, Callable[[Path], GeneratedWorkspace]] = {
        "mixed": lambda root: generate_workspace(
            root, WorkspaceSpec(6, 2) if args.quick else WorkspaceSpec(30, 6)),
    }
    if "compile_heavy" in args.scenarios:
        from benchmarks.compile_heavy import generate_compile_heavy

        makers["compile_heavy"] = generate_compile_heavy
    results = []
    try:
        for name in args.scenarios:
            results.append(bench.scenario(name, makers[name]))
    except CommandFailed as exc:
        print(f"benchmark aborted: {exc}", file=sys.stderr)
        return 1
    command = "python benchmarks/cache.py " + " ".join(argv if argv is not None else sys.argv[1:])
    print(render(results, details, command.strip(), started))
    if args.json:
        args.json.write_text(json.dumps({r.scenario: {k: m.as_dict() for k, m in r.runs.items()}
                                         for r in results}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
