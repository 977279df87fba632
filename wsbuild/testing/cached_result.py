"""A package's last passing test result, reused while nothing its tests read changed (asked
of record/tested.py, in the dirty check's words): what enters the key (`TestKey`), what its test run was observed to read (`CachedResult.reads`,
`.environment`: observe/, as a build's record holds its steps'), and the record kept of it in
build/<pkg>/.wsbuild/test_result.json (digests only, never an environment value; the
directory is private to the user). A run not fully observed is never reused.

The observed reads hold what the tests imported and opened outside the package (a workspace
package they import without declaring it, through the sourced environment, included), the
configuration files pytest looked for upward (`src/pytest.ini`, `setup.cfg`, …), the programs
they ran, and each variable they read by its value's digest.

The key's parts derive from the packages' records (record/model.py), each compared as written:
- `build`: the key of the package's own record (what decided its build's output);
- `closure`: the record key of every workspace package of its test closure (its direct
  dependencies and, recursively, their run dependencies), standing in for their installed
  output, and for one built with --symlink-install also its own files' signatures (its install
  links to them); a package without a record (built by another tool) is never reused;
- `underlays`: the stat signatures of the installed files of every package of the test closure
  that a chained workspace underlay provides (found through the test environment's
  AMENT_PREFIX_PATH, followed through their installed package.xml's run dependencies): an
  underlay rebuilt under the overlay's tests runs them again;
- `sources`: the stat signatures of the package's own files, by the record's rule
  (record/own_files.py), and of the files its test runner names (`KeyInputs.files`; CTest's:
  CTestTestfile.cmake and ninja's log): a test edited without a rebuild runs again;
- `options`: what `wsbuild test` hands the tool (its own arguments only: --pytest-args or
  --ctest-args, then the package's own; the retest counts, --strict-linters, where results
  go, the install layout, the interpreter) and wsbuild's version;
- `tools`: the interpreter, and the tools its test runner names (`KeyInputs.tools`; CTest's:
  the ctest binary).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild import inputs
from wsbuild.files import atomic_write, private_directory
from wsbuild.build_types.junit import Counts
from wsbuild.record.model import decode_outside, digest_of, encode_outside
from wsbuild.record.outside import OutsideReads
from wsbuild.record.tested import TestKey, TestRun

#: the record of the package's last passing test result
TEST_RECORD = Path(".wsbuild") / "test_result.json"
RECORD_FORMAT = 3


#: type and mode, inode, size, modification and change times of a path (through links)
stat_signature = inputs.signature


def interpreter_tools(python_executable: str) -> str:
    """What every package's test tools share: the interpreter (what the tests read of its
    library and distributions is observed)."""
    return digest_of([python_executable, stat_signature(python_executable),
                    stat_signature(inputs.realpath(python_executable))])


@dataclass(frozen=True, slots=True)
class CachedResult:
    """A passing result kept for reuse: its key, its counts, and where its files are."""

    key: TestKey
    counts: Counts
    #: the JUnit files, each with its size and mtime when the run wrote it
    result_files: dict[str, tuple[int, int]] = field(default_factory=dict)
    #: the log directory of the run that produced it
    log_dir: Path | None = None
    seconds: float = 0.0
    #: what the test run was observed to read outside the package, and the variables it read
    #: (their digests as it saw them)
    reads: OutsideReads = field(default_factory=OutsideReads)
    environment: dict[str, str] = field(default_factory=dict)
    #: why the run was not fully observed (such a result is never reused)
    unobserved: tuple[str, ...] = ()

    def run(self) -> TestRun:
        """What record/tested.py compares: the key, the reads, the result files kept."""
        return TestRun(self.key, self.reads, self.environment, self.unobserved,
                       results_kept=self.files_unchanged())

    def files_unchanged(self) -> bool:
        """The JUnit files are still those the run wrote (what `test-result` reads)."""
        for path, (size, mtime_ns) in self.result_files.items():
            try:
                st = inputs.stat(path)
            except OSError:
                return False
            if (st.st_size, st.st_mtime_ns) != (size, mtime_ns):
                return False
        return True


def file_stamps(paths: Iterable[Path]) -> dict[str, tuple[int, int]]:
    stamps = {}
    for path in paths:
        st = inputs.stat(path)
        stamps[str(path)] = (st.st_size, st.st_mtime_ns)
    return stamps


def read_cached_result(build_dir: Path) -> CachedResult | None:
    try:
        data = json.loads(inputs.read_text(build_dir / TEST_RECORD))
        if data.get("format") != RECORD_FORMAT:
            return None
        key = data["key"]
        return CachedResult(
            key=TestKey(build=key["build"], closure=dict(key["closure"]),
                        sources=key["sources"], options=key["options"], tools=key["tools"],
                        underlays=key["underlays"]),
            counts=Counts(**data["counts"]),
            result_files={p: (int(s), int(m)) for p, (s, m) in data["result_files"].items()},
            log_dir=Path(data["log_dir"]) if data.get("log_dir") else None,
            seconds=float(data.get("seconds", 0.0)),
            reads=decode_outside(data["reads"]),
            environment={str(k): str(v) for k, v in data["environment"].items()},
            unobserved=tuple(str(why) for why in data["unobserved"]),
        )
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def write_cached_result(build_dir: Path, result: CachedResult) -> None:
    key = result.key
    data = {
        "format": RECORD_FORMAT,
        "key": {"build": key.build, "closure": dict(sorted(key.closure.items())),
                "sources": key.sources, "options": key.options, "tools": key.tools,
                "underlays": key.underlays},
        "reads": encode_outside(result.reads),
        "environment": dict(sorted(result.environment.items())),
        "unobserved": list(result.unobserved),
        "counts": {"tests": result.counts.tests, "errors": result.counts.errors,
                   "failures": result.counts.failures, "skipped": result.counts.skipped},
        "result_files": {p: list(s) for p, s in sorted(result.result_files.items())},
        "log_dir": str(result.log_dir) if result.log_dir else "",
        "seconds": round(result.seconds, 3),
    }
    private_directory(build_dir / TEST_RECORD.parent)
    atomic_write(build_dir / TEST_RECORD, json.dumps(data, indent=1) + "\n", mode=0o600)


def forget_cached_result(build_dir: Path) -> None:
    """Called before a package's tests run: only a run that passed leaves a record."""
    try:
        (build_dir / TEST_RECORD).unlink()
    except FileNotFoundError:
        pass
