"""A mutation pass over the decisions that make "up to date", "restored" and "cached" right:
every branch of the one dirty check (record/dirty.py), every part of the record's two keys
(record/model.py), of the cached test result's key and reuse (testing/), and of the build
cache's key and restore proof (cache/). Each mutant removes one of them with a one-line change
made in place, in the checkout the project venv's editable install runs (the tests start
`wsbuild` as a user does, in a fresh terminal's environment: a copy on PYTHONPATH would be
dropped, and its mutants never run), and undone after it (commit first: a crash is undone by
`git checkout -- wsbuild`); a mutant the tests that hold it do not kill (every test passes) is
a check the suite does not make.

    .venv/bin/python benchmarks/mutants.py               # every mutant (about an hour)
    .venv/bin/python benchmarks/mutants.py --only dirty  # the mutants whose name has "dirty"
    .venv/bin/python benchmarks/mutants.py --list        # what would be mutated

Prints one line per mutant (killed, by which test, or SURVIVED) and exits 1 when one
survived."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

#: the tests that hold the record, the caches and the plan (each mutant runs the ones it names
#: first, then these, stopping at the first failure)
HOLDERS = ("tests/test_record.py", "tests/test_observed.py", "tests/test_up_to_date.py",
           "tests/test_early_cutoff.py", "tests/test_test_cache.py", "tests/test_cache_build.py",
           "tests/test_dry_run.py")


@dataclass(frozen=True)
class Mutant:
    name: str
    path: str
    #: the exact text replaced (once), and what replaces it
    old: str
    new: str
    #: the tests most likely to kill it, run first
    tests: tuple[str, ...] = ()


def _dropped(path: str, name: str, line: str, tests: tuple[str, ...] = ()) -> Mutant:
    """A mutant that drops a `return Reason(...)` of the dirty check: the branch answers
    "nothing changed"."""
    return Mutant(name, path, line, line.replace("return Reason(", "return None and Reason(", 1),
                  tests)


DIRTY = "wsbuild/record/dirty.py"
MODEL = "wsbuild/record/model.py"
TESTS = ("tests/test_test_cache.py", "tests/test_observed.py")
CONFIGURED = "wsbuild/record/configured.py"
CONFIGURE_TESTS = ("tests/test_configured.py", "tests/test_build_cmake_options.py",
                   "tests/test_ninja.py")
#: record/tested.py's pure tests, which kill its mutants in seconds, before the builds
TESTED = ("tests/test_test_cache.py::test_a_rerun_has_a_typed_reason_for_each_way_a_result_stops_holding",
          "tests/test_test_cache.py::test_a_changed_key_says_what_changed_first_in_the_dirty_checks_words",
          *TESTS)
MUTANTS: tuple[Mutant, ...] = (
    _dropped(DIRTY, "dirty: unfinished",
             '        return Reason(Dirty.UNFINISHED, "the previous build did not finish")',
             ("tests/test_build_concurrency.py", "tests/test_up_to_date.py")),
    _dropped(DIRTY, "dirty: forced", '        return Reason(Dirty.FORCED, "forced")',
             ("tests/test_build_cmake_options.py", "tests/test_dry_run.py")),
    _dropped(DIRTY, "dirty: options",
             '        return Reason(Dirty.OPTIONS, "build options changed: " + "; ".join(changed), '
             'changed)', ("tests/test_record.py", "tests/test_package_options.py")),
    Mutant("dirty: environment", DIRTY,
           "    if changed_variables:\n        return variables_changed(",
           "    if False:\n        return variables_changed(",
           ("tests/test_record.py", "tests/test_observed.py")),
    Mutant("dirty: source", DIRTY,
           "    if (old.own_digest or files_digest(old.own)) != now.own.digest:",
           "    if False:", ("tests/test_record.py", "tests/test_incremental.py")),
    Mutant("dirty: dependency rebuilt, not cut off", DIRTY,
           "    if changed_deps and not cutoff:", "    if False:",
           ("tests/test_record.py", "tests/test_early_cutoff.py")),
    Mutant("dirty: dependency built first (cutoff later)", DIRTY, "    if waiting:",
           "    if False:", ("tests/test_early_cutoff.py", "tests/test_record.py")),
    Mutant("dirty: outside read changed", DIRTY, "    if outside is not None:\n        changed =",
           "    if False:\n        changed =", ("tests/test_record.py", "tests/test_observed.py")),
    Mutant("dirty: install damaged", DIRTY, "    if damaged is not None:", "    if False:",
           ("tests/test_observed.py",)),
    Mutant("dirty: not fully observed", DIRTY, "    if not record.complete:",
           "    if False:", ("tests/test_record.py",)),
    Mutant("dirty: volatile", DIRTY, "    if record.volatile:", "    if False:",
           ("tests/test_observed.py", "tests/test_record.py")),
    Mutant("changed_read: dependencies", DIRTY,
           "            if not key.startswith(PENDING) and record.dependencies.get(dep) != key:",
           "            if False:", ("tests/test_record.py", "tests/test_cache_build.py",
                                 "tests/test_early_cutoff.py")),
    Mutant("changed_read: variables", DIRTY,
           "        if changed_variables:\n            return Reason(Dirty.ENVIRONMENT, f\"read",
           "        if False:\n            return Reason(Dirty.ENVIRONMENT, f\"read",
           ("tests/test_observed.py",)),
    Mutant("changed_read: outside reads", DIRTY,
           "    if changed is not None:\n        return Reason(Dirty.EXTERNAL, f\"read",
           "    if False:\n        return Reason(Dirty.EXTERNAL, f\"read",
           ("tests/test_observed.py", "tests/test_cache_build.py")),
    Mutant("inputs key: own files", MODEL,
           "    return digest_of([package, build_type, own_digest, settings,",
           "    return digest_of([package, build_type, settings,",
           ("tests/test_cache_build.py",)),
    Mutant("inputs key: settings", MODEL,
           "    return digest_of([package, build_type, own_digest, settings,",
           "    return digest_of([package, build_type, own_digest,",
           ("tests/test_cache_build.py", "tests/test_package_options.py")),
    Mutant("inputs key: dependencies' inputs keys", MODEL,
           "                      sorted(dependency_inputs.items())])",
           "                      ])", ("tests/test_cache_build.py",)),
    Mutant("key: outside reads", MODEL,
           "    return digest_of([inputs_key, outside.digest(), sorted(dependencies.items()),",
           "    return digest_of([inputs_key, sorted(dependencies.items()),",
           ("tests/test_early_cutoff.py", "tests/test_test_cache.py")),
    Mutant("key: dependencies' keys", MODEL,
           "    return digest_of([inputs_key, outside.digest(), sorted(dependencies.items()),",
           "    return digest_of([inputs_key, outside.digest(),",
           ("tests/test_test_cache.py", "tests/test_early_cutoff.py")),
    Mutant("key: variables", MODEL,
           "                      sorted(environment.items()), environment_names])",
           "                      environment_names])", ("tests/test_record.py",)),
    Mutant("test key: the build", "wsbuild/testing/test_key.py",
           "            build=own.key, closure=", "            build=\"\", closure=",
           ("tests/test_test_cache.py::test_a_package_rebuilt_for_a_variable_its_build_read_runs_its_tests_again",
            *TESTS)),
    Mutant("test key: comparison", "wsbuild/record/tested.py",
           "    if last.key != key:", "    if False:", TESTED),
    Mutant("test reuse: what the run read", "wsbuild/record/tested.py",
           "    if changed is not None:\n        return Reason(Dirty.EXTERNAL",
           "    if False:\n        return Reason(Dirty.EXTERNAL", TESTED),
    Mutant("test reuse: not fully observed", "wsbuild/record/tested.py",
           "    if last.unobserved:", "    if False:", TESTED),
    Mutant("test reuse: result files", "wsbuild/record/tested.py",
           "    if not last.results_kept:", "    if False:", TESTED),
    Mutant("test reuse: variables", "wsbuild/record/tested.py",
           "        if names:\n            return Reason(Dirty.ENVIRONMENT",
           "        if False:\n            return Reason(Dirty.ENVIRONMENT",
           ("tests/test_test_cache.py",)),
    Mutant("cache proof: the entry's inputs key", "wsbuild/cache/run.py",
           "    if record.inputs_key != inputs_key:", "    if False:",
           ("tests/test_record.py", "tests/test_cache_build.py")),
    Mutant("cache store: incomplete or volatile entries", "wsbuild/cache/run.py",
           "        if not package_record.complete or package_record.volatile:",
           "        if False:", ("tests/test_cache_build.py", "tests/test_observed.py")),
    Mutant("inputs key: install prefix", "wsbuild/builder/plan.py",
           '        "install_prefix": str(prefix),\n', "",
           ("tests/test_cache_build.py",)),
    Mutant("configure: arguments", CONFIGURED, "    if last.args != now.args:", "    if False:",
           CONFIGURE_TESTS),
    Mutant("configure: compilers", CONFIGURED, "    if compilers:", "    if False:",
           CONFIGURE_TESTS),
    Mutant("configure: what it read changed", CONFIGURED, "    if read:", "    if False:",
           ("tests/test_configured.py", "tests/test_observed.py")),
    Mutant("configure: unfinished", CONFIGURED, "    if last is None:", "    if False:",
           CONFIGURE_TESTS),
    Mutant("replay: environment", "wsbuild/engine/replay.py",
           '    if environment_reason(recording["key"]["environ"], environ) is not None:',
           "    if False:", ("tests/test_noop_replay.py",)),
)


def run_mutant(mutant: Mutant, root: Path, timeout: float) -> tuple[bool, str]:
    """(killed, by what) for `mutant` applied in the checkout `root` (and undone after). In
    place: the tests start `wsbuild` as the user does, in a fresh terminal's environment
    (tests/test_build_helpers.py's `clean_env` drops PYTHONPATH), so only the checkout the
    project venv's editable install points at is the code they run."""
    path = root / mutant.path
    original = path.read_text()
    if original.count(mutant.old) != 1:
        return False, f"NOT APPLIED: the text to mutate is not in {mutant.path} once"
    path.write_text(original.replace(mutant.old, mutant.new, 1))
    try:
        tests = list(dict.fromkeys((*mutant.tests, *HOLDERS)))
        env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
        for test in tests:
            done = subprocess.run(
                [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider",
                 "-n", "2", test], cwd=root, env=env, capture_output=True, text=True,
                timeout=timeout, check=False)
            if done.returncode not in (0, 5):
                failed = [line for line in done.stdout.splitlines()
                          if line.startswith(("FAILED", "ERROR"))]
                return True, failed[0] if failed else f"{test} (exit {done.returncode})"
        return False, "SURVIVED: every test passed"
    finally:
        path.write_text(original)


def _undone_on_signals() -> None:
    """SIGTERM and SIGHUP end the run as Ctrl-C does: through `run_mutant`'s `finally`,
    which puts the mutated file back."""
    import signal

    def stop(signum: int, _frame: object) -> None:
        raise KeyboardInterrupt(f"signal {signum}")

    for signum in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, stop)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", default="", help="the mutants whose name has this")
    parser.add_argument("--list", action="store_true", help="list the mutants, run none")
    parser.add_argument("--timeout", type=float, default=1800.0, help="seconds per test file")
    args = parser.parse_args(argv)
    chosen = [m for m in MUTANTS if args.only in m.name]
    if args.list:
        for mutant in chosen:
            print(f"{mutant.name}: {mutant.path}")
        return 0
    dirty = subprocess.run(["git", "status", "--porcelain", "--", "wsbuild"], cwd=REPO,
                           capture_output=True, text=True, check=False).stdout
    if dirty:
        print("wsbuild/ has uncommitted changes: commit them first (each mutant is made in "
              "place and undone, and `git checkout -- wsbuild` undoes one a crash left)",
              file=sys.stderr)
        return 2
    _undone_on_signals()
    started = time.monotonic()
    survived = 0
    for mutant in chosen:
        killed, why = run_mutant(mutant, REPO, args.timeout)
        survived += not killed
        print(f"{'killed  ' if killed else 'SURVIVED'} {mutant.name}: {why}", flush=True)
    print(f"mutants: {len(chosen)}, killed {len(chosen) - survived}, survived {survived} "
          f"({(time.monotonic() - started) / 60:.1f} min)")
    return 1 if survived else 0


if __name__ == "__main__":
    sys.exit(main())
