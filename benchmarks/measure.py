"""Timing one tool's command on one workspace: wall clock, CPU, repeats, and what it rebuilt."""

from __future__ import annotations

import os
import re
import resource
import shutil
import statistics
import subprocess
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

#: runs shorter than this get no contention figure (too few /proc/stat ticks to tell)
MIN_CONTENTION_SECONDS = 1.0

#: both tools print this line for every package they (re)built
_FINISHED = re.compile(r"^Finished <<< (\S+)", re.MULTILINE)


class CommandFailed(RuntimeError):
    """A timed command exited non-zero: the benchmark stops, its output says why."""


@dataclass(frozen=True, slots=True)
class Sample:
    """One timed run."""

    seconds: float
    #: user + system time of the command and all its children
    cpu_seconds: float
    output: str
    rebuilt: tuple[str, ...] = ()
    #: 1-minute load average when the run started (other processes share the machine)
    load: float = 0.0
    #: CPU seconds the whole machine spent busy during the run minus `cpu_seconds`: what other
    #: processes (not this command) used; steal is what the hypervisor gave other machines
    other_cpu: float = 0.0
    steal: float = 0.0

    @property
    def contention(self) -> float:
        """Share of the machine's CPU capacity other processes used during the run (0..1).

        0 for runs shorter than `MIN_CONTENTION_SECONDS`: /proc/stat counts in 10 ms ticks."""
        if self.seconds < MIN_CONTENTION_SECONDS:
            return 0.0
        cpus = os.cpu_count() or 1
        return (self.other_cpu + self.steal) / (self.seconds * cpus)


@dataclass(slots=True)
class Measurement:
    """Repeated runs of one command; `median` is what the tables show."""

    samples: list[Sample] = field(default_factory=list)

    @property
    def median(self) -> float:
        return statistics.median(s.seconds for s in self.samples)

    @property
    def best(self) -> float:
        return min(s.seconds for s in self.samples)

    @property
    def contention(self) -> float:
        """The worst share of the CPUs other processes took during one of the runs."""
        return max(s.contention for s in self.samples)

    @property
    def cpu_median(self) -> float:
        return statistics.median(s.cpu_seconds for s in self.samples)

    @property
    def runs(self) -> int:
        return len(self.samples)

    @property
    def last(self) -> Sample:
        return self.samples[-1]

    def as_dict(self) -> dict[str, object]:
        return {
            "median_s": round(self.median, 4),
            "best_s": round(self.best, 4),
            "runs": [round(s.seconds, 4) for s in self.samples],
            "cpu_s": [round(s.cpu_seconds, 4) for s in self.samples],
            "rebuilt": [len(s.rebuilt) for s in self.samples],
            "load": [round(s.load, 2) for s in self.samples],
            "contention": [round(s.contention, 3) for s in self.samples],
        }


def _machine_cpu() -> tuple[float, float]:
    """(busy, steal) CPU seconds of the whole machine since boot, from /proc/stat."""
    try:
        with open("/proc/stat", encoding="ascii") as stream:
            fields = [int(v) for v in stream.readline().split()[1:]]
    except (OSError, ValueError):
        return 0.0, 0.0
    tick = os.sysconf("SC_CLK_TCK")
    user, nice, system, _idle, _iowait, irq, softirq, steal = (fields + [0] * 8)[:8]
    return (user + nice + system + irq + softirq) / tick, steal / tick


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_timed(cmd: Sequence[str], *, cwd: Path, env: Mapping[str, str], log_file: Path | None,
              timeout: float = 3600) -> Sample:
    """Run `cmd` once (stdin closed, output captured), raise `CommandFailed` on a non-zero exit."""
    load = os.getloadavg()[0]
    busy_before, steal_before = _machine_cpu()
    cpu_before = _children_cpu()
    start = time.perf_counter()
    done = subprocess.run(list(cmd), cwd=cwd, env=dict(env), stdin=subprocess.DEVNULL,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=timeout)
    seconds = time.perf_counter() - start
    cpu = _children_cpu() - cpu_before
    busy_after, steal_after = _machine_cpu()
    other = max(0.0, busy_after - busy_before - cpu)
    if log_file is not None:
        log_file.parent.mkdir(parents=True, exist_ok=True)
        with log_file.open("a", encoding="utf-8") as stream:
            stream.write(f"$ (cd {cwd} && {' '.join(cmd)})  # {seconds:.3f}s exit {done.returncode}\n")
            stream.write(done.stdout)
            stream.write("\n")
    if done.returncode != 0:
        tail = "\n".join(done.stdout.splitlines()[-30:])
        raise CommandFailed(f"{' '.join(cmd)} (in {cwd}) exited {done.returncode}:\n{tail}")
    return Sample(seconds=seconds, cpu_seconds=cpu, output=done.stdout,
                  rebuilt=tuple(_FINISHED.findall(done.stdout)), load=load, other_cpu=other,
                  steal=max(0.0, steal_after - steal_before))


def repeat(cmd: Sequence[str], runs: int, *, cwd: Path, env: Mapping[str, str],
           log_file: Path | None) -> Measurement:
    measurement = Measurement()
    for _ in range(runs):
        measurement.samples.append(run_timed(cmd, cwd=cwd, env=env, log_file=log_file))
    return measurement


#: the folder, beside the workspaces, where discard() moves trees
DISCARDED = ".discarded"


def discard(path: Path, work_dir: Path) -> None:
    """Move `path` (a workspace, or its build/, install/, log/) into `work_dir`'s `DISCARDED`
    folder rather than delete it.

    On ext4, a tree deleted just before a timed run slows every file and directory that run
    creates for about a minute: the inode allocator skips recently freed inodes, reading
    their table blocks (`recently_deleted` tops a perf profile). A warm-cache restore of the
    mixed workspace took 1.0-1.2 s right after an `rm -rf`, 0.55 s after a `mv`. Deleting
    between runs would time the deletion, not the tool; empty_discarded() deletes once the
    timings are done."""
    if not os.path.lexists(path):
        return
    trash = work_dir / DISCARDED
    trash.mkdir(exist_ok=True)
    path.rename(trash / f"{path.parent.name}-{path.name}.{time.monotonic_ns()}")


def empty_discarded(work_dir: Path) -> None:
    """Delete what discard() moved into `work_dir`'s `DISCARDED` (after the last timed run)."""
    shutil.rmtree(work_dir / DISCARDED, ignore_errors=True)


def clean_outputs(workspace: Path) -> None:
    """Move build/, install/ and log/ out of the way: the next build is a full one."""
    for name in ("build", "install", "log"):
        discard(workspace / name, workspace.parent)


def source_command(workspace: Path) -> list[str]:
    """What a user types in a fresh terminal, minus the terminal: bash without rc files."""
    return ["bash", "--noprofile", "--norc", "-c", f". {workspace / 'install' / 'setup.bash'}"]


def sourced_prefixes(workspace: Path, env: Mapping[str, str]) -> list[str]:
    """AMENT_PREFIX_PATH after sourcing the workspace (to check both scripts do the same job)."""
    script = f". {workspace / 'install' / 'setup.bash'} && printf '%s' \"$AMENT_PREFIX_PATH\""
    done = subprocess.run(["bash", "--noprofile", "--norc", "-c", script], cwd=workspace,
                          env=dict(env), capture_output=True, text=True, check=True)
    return [p for p in done.stdout.split(os.pathsep) if p]
