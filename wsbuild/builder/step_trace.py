"""The build-step oracle of the test suite: with WSBUILD_STEP_TRACE naming a file, every command
step of a package's build runs under `strace -f` (Debian's strace, filtered by seccomp-bpf to
open, openat and execve), and once the package's record is written, each file a step read that
the record does not hold is appended to that file, naming the package, the step and the file
(Shake's lint, Bazel's sandbox). Never on in a user's run.

A read counts when a step opened a file for reading and got it: failed opens and directory
listings are the searches of include, module and package paths (`find_package`, the compiler's
`-I`), which no build system records either (a glob that must be redone, CMake's
`CONFIGURE_DEPENDS`, is in the record by its build system's list). The record holds a read
when the file is one of the package's own files, or the record's outside files hold it. Not files the record must hold (`TOOLS`): what the
package's build writes (its build directory, its stage and install prefix, what a step
created), the programs the steps ran and the shared libraries and files those programs are
made of (the compilers' own directories, CMake's modules, the interpreter's standard library
and installed distributions: the record holds the programs by content, the interpreter by
path and version), and the machine's own state (/proc, /sys, /dev, /etc, locales)."""

from __future__ import annotations

import os
import re
import sys
import sysconfig
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.record.model import PackageRecord

#: the environment variable naming the oracle's file
TRACE_VARIABLE = "WSBUILD_STEP_TRACE"
#: beside the oracle's file, one line per package it checked: steps, reads, unrecorded, name
CHECKED_SUFFIX = ".checked"
#: an open that succeeded: the syscall, its arguments, and the path strace -y resolved
_OPEN = re.compile(r"^\d+\s+(?:open|openat|openat2)\((?P<args>.*)\) = \d+<(?P<path>.*)>$")
_EXECVE = re.compile(r'^\d+\s+execve\("(?P<path>(?:[^"\\]|\\.)*)",.* = 0$')
_MULTIARCH = getattr(sys.implementation, "_multiarch", "x86_64-linux-gnu")
#: directories whose files are the machine's or the tools', never a package's inputs
_SYSTEM = ("/proc/", "/sys/", "/dev/", "/etc/", "/run/", "/usr/lib/locale/",
           "/usr/share/locale/", "/usr/lib/gcc/", "/usr/libexec/gcc/", "/usr/share/zoneinfo/",
           f"/usr/lib/{_MULTIARCH}/gconv/", "/usr/lib/bfd-plugins/",
           f"/usr/lib/{_MULTIARCH}/bfd-plugins/")
#: shared libraries, and the C library's startup files and archive the linker adds itself
_TOOL_FILE = re.compile(r"(\.so(\.\d+)*|/[A-Za-z]?crt[^/]*\.o|/libc_nonshared\.a)$")


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


def _tool_roots() -> tuple[str, ...]:
    """The interpreter's standard library and installed distributions, CMake's modules, and
    the compiler caches' own files."""
    paths = sysconfig.get_paths()
    roots = {paths["stdlib"], paths["platstdlib"], paths["purelib"], paths["platlib"],
             sys.base_prefix + os.sep + "lib"}
    roots.update(str(p) for p in Path("/usr/share").glob("cmake-*"))
    home = Path.home()
    caches = Path(os.environ.get("XDG_CACHE_HOME") or home / ".cache")
    roots.update(str(p) for p in (caches / "ccache", caches / "sccache", home / ".ccache"))
    roots.update(os.environ[v] for v in ("CCACHE_DIR", "SCCACHE_DIR") if os.environ.get(v))
    return tuple(sorted(root.rstrip(os.sep) + os.sep for root in roots))


def unrecorded(record: PackageRecord, traces: Mapping[str, Path], *, source_dir: Path,
               outputs: Iterable[Path]) -> tuple[list[tuple[str, str]], int]:
    """(step, path) of every read of the traced steps that `record` does not hold, and how many
    reads were checked; `outputs`: the package's build directory, stage and prefix."""
    own = os.path.realpath(source_dir) + os.sep
    inside = tuple({os.path.realpath(p) + os.sep for p in outputs}
                   | {os.path.normpath(p) + os.sep for p in outputs})
    held = {os.path.realpath(p) for p in record.outside.files} | set(record.outside.files)
    # an own file that is a symlink out of the package is read where it points
    held |= {os.path.realpath(source_dir / rel.partition("\0")[0]) for rel in record.own}
    tools = _tool_roots() + _SYSTEM
    found: list[tuple[str, str]] = []
    checked = 0
    for step, trace in traces.items():
        reads = step_reads(trace)
        programs = reads.programs
        for path in reads.read:
            checked += 1
            if (path + os.sep).startswith(inside) or (path + os.sep).startswith(own) \
                    or (path + os.sep).startswith(tools) or path in programs \
                    or _TOOL_FILE.search(path) or path in reads.written or path in held \
                    or not os.path.lexists(path):  # a step's own temporary (cc1's /tmp/cc*.s)
                continue
            found.append((step, path))
    return found, checked


@dataclass(slots=True)
class StepTraces:
    """One package build's traced steps: none unless the oracle is on."""

    file: str | None = field(default_factory=trace_file)
    traces: dict[str, Path] = field(default_factory=dict)

    def command(self, argv: Sequence[str], step: str, build_dir: Path,
                env: Mapping[str, str]) -> tuple[Sequence[str], Mapping[str, str]]:
        """`argv` and `env`, under strace when the oracle is on (its trace in the build
        directory; the observer's library loaded into the traced program, not into strace)."""
        if self.file is None:
            return argv, env
        from wsbuild.files import private_directory

        directory = private_directory(build_dir / ".wsbuild" / "trace")
        output = directory / f"{len(self.traces) + 1:02d}-{step or 'step'}.strace"
        self.traces[f"{step or 'step'} ({argv[0]})"] = output
        preloaded = {name: env[name] for name in ("LD_PRELOAD",) if name in env}
        return traced(argv, output, preloaded), {k: v for k, v in env.items()
                                                  if k not in preloaded}

    def check(self, package: str, record: PackageRecord, source_dir: Path,
              outputs: Iterable[Path]) -> None:
        """What the traced steps read that the record lacks, into the oracle's file."""
        if self.file is None or not self.traces:
            return
        found, checked = unrecorded(record, self.traces, source_dir=source_dir,
                                    outputs=outputs)
        report(self.file, package, found, checked, len(self.traces))


def report(file: str, package: str, found: list[tuple[str, str]], checked: int,
           steps: int) -> None:
    """Append the unrecorded reads to the oracle's file, and what was checked beside it."""
    if found:
        with open(file, "a", encoding="utf-8") as handle:
            handle.writelines(f"{package}\t{step}\t{path}\n" for step, path in found)
    with open(file + CHECKED_SUFFIX, "a", encoding="utf-8") as handle:
        handle.write(f"{steps}\t{checked}\t{len(found)}\t{package}\n")
