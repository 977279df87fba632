"""The build-step oracle of the test suite: with WSBUILD_STEP_TRACE naming a file, every command
step of a package's build runs under `strace -f` (Debian's strace, filtered by seccomp-bpf to
open, openat and execve), and so does the warm helper that reads a Python package's setup.py
(a helper of its own, traced from its start: what it imported then is the package's too);
once the package's record is written, each file a step read that the record does not hold is
appended to that file, naming the package, the step and the file (Shake's lint, Bazel's
sandbox). Never on in a user's run. It is the independent check of the observer (observe/):
strace sees the system calls, the observer what the C library and Python are asked.

A read counts when a step opened a file for reading and got it (failed opens and directory
listings are searches, which the record holds as probes and listings; strace is not asked
about them). The record holds a read when the file is one of the package's own files, or the
record's outside files hold it (by its path, or by where the path leads). Nothing is exempt for
where it lies: not the underlay's site-packages, headers or CMake files, not the compilers'
directories, not the system's. Left out are only what is no input by what it is: what the
package's build writes (its build directory, stage and install prefix, what a step wrote),
the machine's running state (`/proc`, `/sys`, `/dev`), the observer's own files, a compiler
cache's storage (a cache returns what the compiler would make from what it reads: the sources
and headers it hashes are reads of its own process), and a file gone by the end (a step's own
temporary). A record of steps not fully observed is not checked (such a package builds every
time); the checked file says so."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.files import private_directory
from wsbuild.record.model import PackageRecord
from wsbuild.patterns import lazy

#: the environment variable naming the oracle's file
TRACE_VARIABLE = "WSBUILD_STEP_TRACE"
#: beside the oracle's file, one line per package it checked: steps, reads, unrecorded, name
CHECKED_SUFFIX = ".checked"
#: an open that succeeded: the syscall, its arguments, and the path strace -y resolved
_OPEN = lazy(r"^\d+\s+(?:open|openat|openat2)\((?P<args>.*)\) = \d+<(?P<path>.*)>$")
_EXECVE = lazy(r'^\d+\s+execve\("(?P<path>(?:[^"\\]|\\.)*)",.* = 0$')
#: the machine's running state
_PSEUDO = ("/proc/", "/sys/", "/dev/")


def trace_file() -> str | None:
    """The oracle's file when the build steps are traced (the suite), else None."""
    return os.environ.get(TRACE_VARIABLE) or None


def traced(argv: Sequence[str], output: Path, env_of_traced: Mapping[str, str] = {}
           ) -> list[str]:  # noqa: B006
    """`argv` run under strace, its opens and execs written to `output`; `env_of_traced`:
    variables set for the traced program only, not for strace (the observer's library)."""
    settings = [arg for name, value in env_of_traced.items() for arg in ("-E", f"{name}={value}")]
    return ["strace", "-f", "-qq", "--seccomp-bpf", "-y", "-e",
            "trace=open,openat,openat2,execve", "-e", "signal=none", *settings,
            "-o", str(output), "--", *argv]


@dataclass(frozen=True, slots=True)
class StepReads:
    """What one traced step read and ran."""

    read: tuple[str, ...]
    directories: tuple[str, ...]
    written: frozenset[str]
    programs: frozenset[str]


def step_reads(trace: Path) -> StepReads:
    """The files a traced step opened for reading (in order, once each), the directories it
    opened, what it opened for writing, and the programs it ran."""
    read: dict[str, None] = {}
    directories: dict[str, None] = {}
    written: set[str] = set()
    programs: set[str] = set()
    try:
        lines = trace.read_text(errors="replace").splitlines()
    except OSError:
        lines = []
    for line in lines:
        if (match := _OPEN.match(line)) is not None:
            path, args = match.group("path"), match.group("args")
            if "O_WRONLY" in args or "O_RDWR" in args or "O_CREAT" in args:
                written.add(path)
            elif "O_DIRECTORY" in args:
                directories[path] = None
            elif path not in written:
                read[path] = None
        elif (match := _EXECVE.match(line)) is not None:
            programs.add(os.path.realpath(match.group("path")))
    return StepReads(tuple(read), tuple(directories), frozenset(written), frozenset(programs))


def unrecorded(record: PackageRecord, traces: Mapping[str, Path], *, source_dir: Path,
               outputs: Iterable[Path], exempt: Iterable[Path] = ()
               ) -> tuple[list[tuple[str, str]], int]:
    """(step, path) of every read of the traced steps that `record` does not hold, and how many
    reads were checked; `outputs`: the package's build directory, stage and prefix; `exempt`:
    the observer's files and a compiler cache's storage."""
    def prefixes(paths: Iterable[Path]) -> tuple[str, ...]:
        return tuple({os.path.realpath(p) + os.sep for p in paths}
                     | {os.path.normpath(p) + os.sep for p in paths})

    inside = prefixes(outputs) + prefixes(exempt) + _PSEUDO
    held = set(record.outside.files) | {os.path.realpath(p) for p in record.outside.files}
    for rel in record.own:
        path = source_dir / rel.partition("\0")[0]
        held.update((os.path.normpath(path), os.path.realpath(path)))
    found: list[tuple[str, str]] = []
    checked = 0
    for step, trace in traces.items():
        reads = step_reads(trace)
        for path in reads.read:
            checked += 1
            if (path + os.sep).startswith(inside) or path in reads.written \
                    or path in held or os.path.realpath(path) in held \
                    or _source_of(path) in held \
                    or not os.path.lexists(path):  # a step's own temporary (cc1's /tmp/cc*.s)
                continue
            found.append((step, path))
    return found, checked


_PYC = lazy(r"^(?P<dir>.*)/__pycache__/(?P<name>[^/.]+)\.[^/]+?\.pyc$")


def _source_of(path: str) -> str | None:
    """The source of a compiled Python module (what the record holds for it: observe/log.py),
    None for any other file."""
    match = _PYC.match(path) if path.endswith(".pyc") else None
    return f"{match.group('dir')}/{match.group('name')}.py" if match else None


@dataclass(slots=True)
class StepTraces:
    """One package build's traced steps: none unless the oracle is on."""

    file: str | None = field(default_factory=trace_file)
    traces: dict[str, Path] = field(default_factory=dict)

    @property
    def on(self) -> bool:
        return self.file is not None

    def command(self, argv: Sequence[str], step: str, build_dir: Path,
                env: Mapping[str, str]) -> tuple[Sequence[str], Mapping[str, str]]:
        """`argv` and `env`, under strace when the oracle is on (its trace in the build
        directory; the observer's library loaded into the traced program, not into strace)."""
        if self.file is None:
            return argv, env

        directory = private_directory(build_dir / ".wsbuild" / "trace")
        output = directory / f"{len(self.traces) + 1:02d}-{step or 'step'}.strace"
        self.traces[f"{step or 'step'} ({Path(argv[0]).name})"] = output
        preloaded = {name: env[name] for name in ("LD_PRELOAD",) if name in env}
        return traced(argv, output, preloaded), {k: v for k, v in env.items()
                                                  if k not in preloaded}

    def check(self, package: str, record: PackageRecord, source_dir: Path,
              outputs: Iterable[Path], exempt: Iterable[Path] = ()) -> None:
        """What the traced steps read that the record lacks, into the oracle's file."""
        if self.file is None or not self.traces:
            return
        if not record.complete:
            report(self.file, package, [], 0, len(self.traces), note="not fully observed")
            return
        found, checked = unrecorded(record, self.traces, source_dir=source_dir,
                                    outputs=outputs, exempt=exempt)
        report(self.file, package, found, checked, len(self.traces))


def report(file: str, package: str, found: list[tuple[str, str]], checked: int,
           steps: int, note: str = "") -> None:
    """Append the unrecorded reads to the oracle's file, and what was checked beside it."""
    if found:
        with open(file, "a", encoding="utf-8") as handle:
            handle.writelines(f"{package}\t{step}\t{path}\n" for step, path in found)
    with open(file + CHECKED_SUFFIX, "a", encoding="utf-8") as handle:
        handle.write(f"{steps}\t{checked}\t{len(found)}\t{package}"
                     + (f"\t{note}" if note else "") + "\n")
