"""Compiling on other machines through distcc: which hosts, the run's job budget, the chain
with the compiler cache, the local gate, and how many compile jobs ran remotely.

Turned on by `--distribute HOSTS` (distcc's own `DISTCC_HOSTS` syntax, e.g.
`box1/16 box2:3633/16,lzo`), else `WSBUILD_DISTRIBUTE`, else a `distribute:` key of a
defaults file (it sets the option), else `DISTCC_HOSTS` in the environment; `off` turns it off
whatever the environment says. Off when none of them is set.

The chain, as teams run it: ccache is the compiler launcher and calls distcc on a miss
(`CCACHE_PREFIX=distcc`), so a hit sends nothing; without a compiler cache distcc itself is
the launcher. sccache cannot chain distcc (it has a distributed mode of its own, which wsbuild
does not drive): `--compiler-cache sccache` with distribution is an error saying so, and
`--compiler-cache auto` takes only ccache.

One job budget that knows the hosts:
- the run's jobserver (engine/jobserver.py), which make and Ninja both read, holds the local
  cores plus every remote host's slots (its `/LIMIT`, distcc's default 4), so each package's
  make or Ninja may start that many compile jobs;
- local compiles stay within the local cores through distcc's own cross-process locks:
  wsbuild prepends `--localslots=CORES --localslots_cpp=CORES` to the host list (unless the
  user gave them), so jobs distcc runs locally (a fallback, or what cannot be distributed) and
  the preprocessing of remote jobs never exceed the cores, whatever the jobserver allows;
- links and code generators (custom commands) run through a gate, a second jobserver holding
  the local cores only: CMake gets it as `RULE_LAUNCH_LINK` and `RULE_LAUNCH_CUSTOM` through
  `CMAKE_PROJECT_INCLUDE`, and configure steps and Python packages run in the scheduler's
  workers (as many as cores);
- before the first compile every host is probed with a real compile (`DISTCC_FALLBACK=0`): a
  host that is down or refuses the compiler costs one warning and leaves the host list and
  the budget; with no host left the run builds locally with the local budget. A host lost
  during the run makes distcc compile locally, within `--localslots`, and leaves the budget
  too: a thread follows distcc's log and withholds that host's slots from the jobserver.
- every remote wait is bounded: a host that takes a job and then never answers keeps a compile
  waiting `DISTCC_IO_TIMEOUT` seconds (wsbuild's `IO_TIMEOUT_SECONDS` unless the user set it;
  distcc's own default is 300), after which distcc compiles it here and, with
  `DISTCC_BACKOFF_PERIOD` set to the length of any run (in the run's own `DISTCC_DIR`),
  never sends that host another job in this run.

distcc's client log (`DISTCC_LOG`, `log/<run>/distcc.log`) says where each compile ran: the
run's counts come from it.
"""

from __future__ import annotations

import os
import re
import shutil
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from wsbuild.engine.jobserver import Jobserver
from wsbuild.engine.timings import CompileJobs
from wsbuild.errors import WsbuildError
from wsbuild.patterns import lazy

ENV_VAR = "WSBUILD_DISTRIBUTE"
DISTCC_HOSTS = "DISTCC_HOSTS"
OFF = frozenset({"off", "none", "no", "false", "0"})
#: distcc's own defaults for a host without `/LIMIT`
REMOTE_SLOTS = 4
LOCALHOST_SLOTS = 2
#: a probe compile that takes longer counts as a host that does not answer
PROBE_SECONDS = 20.0
#: how long a compile waits for a host that stopped answering before distcc compiles it here
#: (DISTCC_IO_TIMEOUT, unless the user set it): above what one file takes on a build host
IO_TIMEOUT_SECONDS = 30
#: distcc leaves a host that failed a job alone this long (DISTCC_BACKOFF_PERIOD, unless the
#: user set it): longer than any run, so a host is dropped after its first failure
BACKOFF_SECONDS = 7 * 24 * 3600
#: the environment variable the gate reads the local jobserver's FIFO from
GATE_FIFO_VAR = "WSBUILD_LOCAL_JOBS"
#: the environment variable that hands the gate's CMake file to build_types/cmake.py
GATE_CMAKE_VAR = "WSBUILD_LOCAL_GATE_CMAKE"
#: under the build base: the gate and the CMake file that installs it (stable paths, so the
#: configure arguments of a package stay the same from run to run)
GATE_DIR = Path(".wsbuild") / "distribute"

_GATE_SCRIPT = """#!/bin/sh
# wsbuild: a link or code generator runs within the local cores while compiles go to distcc
# hosts. Takes a token from the run's local jobserver ($WSBUILD_LOCAL_JOBS), runs the step,
# gives the token back. Nested steps (a build inside a custom command) pass straight through.
fifo="${WSBUILD_LOCAL_JOBS:-}"
if [ -z "$fifo" ] || [ ! -p "$fifo" ]; then exec "$@"; fi
exec 9<>"$fifo"
token=$(dd bs=1 count=1 <&9 2>/dev/null)
WSBUILD_LOCAL_JOBS= "$@"
rc=$?
printf '%s' "${token:-+}" >&9
exit $rc
"""

_GATE_CMAKE = """# wsbuild --distribute: links and custom commands run within the local cores
set_property(GLOBAL PROPERTY RULE_LAUNCH_LINK "{gate}")
set_property(GLOBAL PROPERTY RULE_LAUNCH_CUSTOM "{gate}")
"""

_COMPLETED = lazy(r"\bcompile (\S+) on (\S+) completed ok")
#: distcc ≥ 3.3 names the source and the host; older ones neither
_FELL_BACK = lazy(r"failed to distribute(?: (\S+) to (\S+))?, running locally instead")


@dataclass(frozen=True, slots=True)
class Host:
    """One host of a `DISTCC_HOSTS` list."""

    #: as written, options included ("box1:3633/16,lzo")
    token: str
    #: the host alone ("box1", "user@box1", "localhost")
    name: str
    slots: int
    local: bool


def parse_hosts(spec: str) -> tuple[list[str], list[Host]]:
    """(option tokens such as `--localslots=4`, hosts) of a `DISTCC_HOSTS` string."""
    options: list[str] = []
    hosts: list[Host] = []
    for token in spec.split():
        if token.startswith("-"):
            options.append(token)
            continue
        if token.startswith("+"):  # +zeroconf: hosts found at run time, slots unknown
            hosts.append(Host(token, token, 0, local=False))
            continue
        hosts.append(_parse_host(token))
    return options, hosts


def _parse_host(token: str) -> Host:
    head = token.split(",", 1)[0]
    limit = re.search(r"/(\d+)", head)
    name = re.split(r"[/:]", head.lstrip("@"), maxsplit=1)[0] if not head.startswith("[") \
        else head.split("]", 1)[0] + "]"
    if head.startswith("@"):
        name = "@" + name
    local = name == "localhost"
    if limit is None:
        slots = LOCALHOST_SLOTS if local else REMOTE_SLOTS
    else:
        slots = int(limit.group(1))
    if slots < 1:
        raise WsbuildError(f"--distribute: host '{token}' has a limit of {slots} jobs",
                           hint="give every host a limit of at least 1, e.g. box1/8")
    return Host(token, name, slots, local)


def distribute_spec(option: str | None, environ: Mapping[str, str]) -> str | None:
    """The host list a run distributes to (None: off): `--distribute` (or the defaults file
    that set it), else WSBUILD_DISTRIBUTE, else DISTCC_HOSTS; `off` turns it off."""
    for value in (option, environ.get(ENV_VAR), environ.get(DISTCC_HOSTS)):
        if value is None or not value.strip():
            continue
        if value.strip().lower() in OFF:
            return None
        _, hosts = parse_hosts(value)
        if not hosts:
            raise WsbuildError(f"--distribute '{value}' names no host",
                               hint="give hosts in DISTCC_HOSTS syntax, e.g. 'box1/16 box2/16'")
        return value.strip()
    return None


@dataclass(slots=True)
class Distribution:
    """One run's distcc: the hosts that answered, the budget, the variables packages get."""

    distcc: Path
    hosts: tuple[Host, ...]
    local_cores: int
    log: Path
    private_dir: Path
    gate_cmake: Path
    environ: dict[str, str] = field(default_factory=dict)
    #: hosts that failed during the run: their slots left the budget
    lost: list[str] = field(default_factory=list)
    _local_jobs: Jobserver | None = None
    _watcher: threading.Thread | None = None
    _stop: threading.Event = field(default_factory=threading.Event)

    @property
    def remote_slots(self) -> int:
        return sum(h.slots for h in self.hosts if not h.local)

    @property
    def budget(self) -> int:
        """Jobs the run's jobserver holds: the local cores plus the remote hosts' slots."""
        return self.local_cores + self.remote_slots

    @property
    def launcher(self) -> str:
        """The compiler launcher when no compiler cache runs in front of distcc."""
        return str(self.distcc)

    def compile_jobs(self) -> CompileJobs:
        """Where this run's compiles ran, from distcc's log (call after `stop_watching()`)."""
        jobs = count_compile_jobs(self.log, tuple(h.name for h in self.hosts if not h.local))
        return replace(jobs, lost=tuple(self.lost))

    def watch(self, jobserver: Jobserver) -> None:
        """Follow distcc's log while the run builds: a host that fails a compile (distcc then
        compiles it here) leaves the budget, its slots withheld from the jobserver."""
        self._watcher = threading.Thread(target=self._follow, args=(jobserver,),
                                         name="distcc-watch", daemon=True)
        self._watcher.start()

    def stop_watching(self) -> None:
        if self._watcher is not None:
            self._stop.set()
            self._watcher.join()
            self._watcher = None

    def _follow(self, jobserver: Jobserver) -> None:
        offset = 0
        while not self._stop.wait(0.5):
            offset = self._scan(offset, jobserver)
        self._scan(offset, jobserver)

    def _scan(self, offset: int, jobserver: Jobserver) -> int:
        try:
            with open(self.log, "rb") as handle:
                handle.seek(offset)
                data = handle.read()
        except OSError:
            return offset
        end = data.rfind(b"\n") + 1
        for line in data[:end].decode(errors="replace").splitlines():
            match = _FELL_BACK.search(line)
            host = self._host(match.group(2)) if match and match.group(2) else None
            if host is not None and host.token not in self.lost:
                self.lost.append(host.token)
                jobserver.withhold(host.slots)
        return offset + end

    def _host(self, written: str) -> Host | None:
        """The host distcc names in a log line ("box1:3633/8")."""
        for host in self.hosts:
            if not host.local and host.token.split(",")[0] == written:
                return host
        bare = re.split(r"[/:]", written, maxsplit=1)[0]
        return next((h for h in self.hosts if not h.local and h.name == bare), None)

    def close(self) -> None:
        self.stop_watching()
        if self._local_jobs is not None:
            self._local_jobs.close()
            self._local_jobs = None
        shutil.rmtree(self.private_dir, ignore_errors=True)


def open_distribution(spec: str, environ: Mapping[str, str], *, cores: int, run_log: Path,
                      build_base: Path, warn: Callable[[str], None]) -> Distribution | None:
    """Probe the hosts of `spec` and set up the run's distcc; None (after one warning) when no
    host can take a compile. Call `close()` when the run ends."""
    import tempfile  # (with random: 2 ms of every build's options, which name this module)

    distcc = _find(environ, "distcc")
    if distcc is None:
        raise WsbuildError("--distribute: no 'distcc' executable on PATH",
                           hint="install it (apt-get install distcc) or leave --distribute off")
    options, hosts = parse_hosts(spec)
    private = Path(tempfile.mkdtemp(prefix="wsbuild-distcc-"))
    try:
        usable, dropped = probe_hosts(distcc, hosts, environ, private)
    except BaseException:
        shutil.rmtree(private, ignore_errors=True)
        raise
    remote = [h for h in usable if not h.local]
    if dropped:
        rest = "compiling on the others" if remote else "building locally"
        warn("distcc: " + "; ".join(f"{h.token} not used ({why})" for h, why in dropped)
             + f": {rest}")
    if not remote:
        shutil.rmtree(private, ignore_errors=True)
        return None
    (private / "distcc").mkdir()
    ours = [o for o in (f"--localslots={cores}", f"--localslots_cpp={cores}")
            if not any(u.split("=")[0] == o.split("=")[0] for u in options)]
    log = run_log / "distcc.log"
    distribution = Distribution(distcc=distcc, hosts=tuple(usable), local_cores=cores, log=log,
                                private_dir=private, gate_cmake=_write_gate(build_base))
    distribution._local_jobs = Jobserver(cores, implicit_slot=False)
    distribution.environ.update({
        DISTCC_HOSTS: " ".join([*ours, *options, *(h.token for h in usable)]),
        "DISTCC_DIR": str(private / "distcc"),
        "DISTCC_LOG": str(log),
        # ccache in front calls distcc on a miss; harmless when distcc is the launcher
        "CCACHE_PREFIX": str(distcc),
        GATE_FIFO_VAR: str(distribution._local_jobs.fifo),
        GATE_CMAKE_VAR: str(distribution.gate_cmake),
    })
    distribution.environ.update(remote_wait_bounds(environ))
    return distribution


def remote_wait_bounds(environ: Mapping[str, str]) -> dict[str, str]:
    """distcc's variables that bound a wait for a host that took a job and then hangs, those
    the user did not set: one wait of `IO_TIMEOUT_SECONDS`, then the host is left alone."""
    bounds = {"DISTCC_IO_TIMEOUT": str(IO_TIMEOUT_SECONDS),
              "DISTCC_BACKOFF_PERIOD": str(BACKOFF_SECONDS)}
    return {name: value for name, value in bounds.items() if not environ.get(name, "").strip()}


def probe_hosts(distcc: Path, hosts: Sequence[Host], environ: Mapping[str, str],
                workdir: Path) -> tuple[list[Host], list[tuple[Host, str]]]:
    """(hosts that compiled a probe, (host, why not) for the others). localhost and zeroconf
    entries are kept unprobed."""
    from concurrent.futures import ThreadPoolExecutor

    compiler = _find(environ, environ.get("CXX", "") or "c++") or Path("c++")
    source = workdir / "probe.cpp"
    source.write_text("int wsbuild_distcc_probe(int x) { return x + 1; }\n")
    to_probe = [h for h in hosts if not h.local and not h.token.startswith("+")]
    with ThreadPoolExecutor(max_workers=max(1, min(16, len(to_probe)))) as pool:
        answers = list(pool.map(
            lambda pair: _probe(distcc, compiler, pair[1], environ, workdir, pair[0]),
            enumerate(to_probe)))
    why_not = {h.token: why for h, why in zip(to_probe, answers) if why is not None}
    usable = [h for h in hosts if h.token not in why_not]
    dropped = [(h, why_not[h.token]) for h in hosts if h.token in why_not]
    return usable, dropped


def _probe(distcc: Path, compiler: Path, host: Host, environ: Mapping[str, str],
           workdir: Path, index: int) -> str | None:
    env = {k: v for k, v in environ.items() if k not in ("MAKEFLAGS", "MFLAGS")}
    state = workdir / f"probe{index}"
    state.mkdir()
    env.update(DISTCC_HOSTS=host.token, DISTCC_FALLBACK="0", DISTCC_DIR=str(state),
               DISTCC_SKIP_LOCAL_RETRY="1")
    env.pop("DISTCC_LOG", None)
    import subprocess  # lazy: off every run that distributes no compile

    try:
        done = subprocess.run([str(distcc), str(compiler), "-c", str(workdir / "probe.cpp"),
                               "-o", str(state / "probe.o")], env=env, cwd=workdir,
                              stdin=subprocess.DEVNULL, capture_output=True, text=True,
                              timeout=PROBE_SECONDS, check=False)
    except subprocess.TimeoutExpired:
        return f"no answer within {PROBE_SECONDS:.0f} s"
    except OSError as exc:
        return str(exc)
    if done.returncode == 0:
        return None
    return _reason(done.stderr)


def _reason(stderr: str) -> str:
    """The line of distcc's output that says why a host took no compile."""
    lines = [line.split(") ", 1)[-1].strip() for line in stderr.splitlines() if line.strip()]
    for needle in ("failed to connect", "refused", "not allowed", "whitelist", "ERROR"):
        for line in lines:
            if needle.lower() in line.lower():
                return line.removeprefix("ERROR: ")
    return lines[-1] if lines else "the probe compile failed"


def count_compile_jobs(log: Path, remote_names: Sequence[str]) -> CompileJobs:
    """Compiles that completed on a remote host, on this machine, and how many of the local
    ones fell back after failing to distribute, from a distcc client log."""
    remote = local = fell_back = 0
    try:
        text = log.read_text(errors="replace")
    except OSError:
        text = ""
    for line in text.splitlines():
        if _FELL_BACK.search(line):
            fell_back += 1
            continue
        match = _COMPLETED.search(line)
        if match is None:
            continue
        if match.group(2) == "localhost":
            local += 1
        else:
            remote += 1
    return CompileJobs(remote=remote, local=local, fell_back=fell_back,
                       hosts=tuple(remote_names))


def gate_cmake_path(build_base: Path) -> Path:
    """The CMake file that installs the gate (a stable path: the plan names it in the
    configure's arguments before the run opens distcc)."""
    return build_base / GATE_DIR / "local_gate.cmake"


def planned_environ(build_base: Path) -> dict[str, str]:
    """What a distributed run sets that the steps' decision reads, as the plan takes it."""
    return {GATE_CMAKE_VAR: str(gate_cmake_path(build_base))}


def _write_gate(build_base: Path) -> Path:
    """The gate script and the CMake file that installs it, under build/.wsbuild/distribute
    (written only when their content changes, so CMake sees the same file every run)."""
    folder = build_base / GATE_DIR
    folder.mkdir(parents=True, exist_ok=True)
    gate = folder / "local_gate.sh"
    _write_if_changed(gate, _GATE_SCRIPT)
    gate.chmod(0o755)
    cmake = gate_cmake_path(build_base)
    _write_if_changed(cmake, _GATE_CMAKE.format(gate=gate))
    return cmake


def _write_if_changed(path: Path, text: str) -> None:
    try:
        if path.read_text() == text:
            return
    except OSError:
        pass
    path.write_text(text)


def _find(environ: Mapping[str, str], name: str) -> Path | None:
    if os.sep in name:
        return Path(name) if os.access(name, os.X_OK) else None
    found = shutil.which(name, path=environ.get("PATH", ""))
    return Path(found) if found else None
