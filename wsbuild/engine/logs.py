"""log/: one directory per run, `latest_<verb>` and `latest` links, the last runs kept; the one
writer of a package's `command.log` (every line redacted: wsbuild/redaction.py)."""

from __future__ import annotations

import os
import time
from pathlib import Path

from wsbuild.redaction import redact

KEEP_RUNS = 10
#: a package's log of what wsbuild did and why, beside its steps' output
COMMAND_LOG = "command.log"


def append_command_log(log_dir: Path, line: str) -> None:
    """Add `line` to `log_dir`'s command.log, its secrets hidden: every writer of one goes
    through here (a build's, a test's, a shard's waits)."""
    log_dir.mkdir(parents=True, exist_ok=True)
    with open(log_dir / COMMAND_LOG, "a") as handle:
        handle.write(redact(line) + "\n")


def new_run_log(log_base: Path, verb: str, markers: tuple[str, ...] = ()) -> Path:
    """Create `log/<verb>_<timestamp>/`, point `latest_<verb>` and `latest` at it, prune old
    runs; `markers`: empty files the log base gets (the caller's tools' ignore markers)."""
    log_base.mkdir(parents=True, exist_ok=True)
    for marker in markers:
        (log_base / marker).touch()
    name = f"{verb}_{time.strftime('%Y-%m-%d_%H-%M-%S')}"
    # runs within the same second count on from the highest number there (more than
    # KEEP_RUNS of them: the first ones are pruned, and their names must not be reused)
    same = [_run_order(p)[1] for p in log_base.iterdir() if p.name == name
            or (p.name.startswith(name + "_") and p.name[len(name) + 1:].isdigit())]
    run_dir = log_base / (f"{name}_{max(same) + 1}" if same else name)
    run_dir.mkdir()
    _link(log_base / f"latest_{verb}", run_dir.name)
    _link(log_base / "latest", f"latest_{verb}")
    _prune(log_base, verb)
    return run_dir


def _link(link: Path, target: str) -> None:
    tmp = link.with_name(link.name + ".tmp")
    if tmp.is_symlink() or tmp.exists():
        tmp.unlink()
    tmp.symlink_to(target)
    os.replace(tmp, link)


def _run_order(run: Path) -> tuple[str, int]:
    """`<verb>_<stamp>_<n>` comes after `<verb>_<stamp>_<n-1>`: the counter is a number."""
    base, _, counter = run.name.rpartition("_")
    return (base, int(counter)) if counter.isdigit() else (run.name, 0)


def _prune(log_base: Path, verb: str) -> None:
    runs = sorted((p for p in log_base.glob(f"{verb}_*") if p.is_dir() and not p.is_symlink()),
                  key=_run_order)
    for old in runs[:-KEEP_RUNS]:
        import shutil  # (not on a replay that prunes nothing)

        shutil.rmtree(old, ignore_errors=True)
