"""Several workspaces at one path at once, as the jobs of a CI matrix each have their checkout at
the same path on their own machine: each command runs in a mount namespace of its own
(`unshare -m`; `unshare -Urm` for a user that is not root) in which its workspace directory is
bind-mounted onto the shared path. The build cache's key holds the absolute install prefix, so
only workspaces at one path share entries. Holds no tests; `benchmarks/shards.py` uses it too.
"""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path

#: runs "$@" after binding $1 onto $2, in $2
_SCRIPT = 'mount --bind "$1" "$2" && cd "$2" && shift 2 && exec "$@"'


def at_path_command(workspace: Path, path: Path, argv: Sequence[str]) -> list[str]:
    """`argv` run in `workspace` seen at `path` (which must exist, an empty directory)."""
    unshare = ["unshare", "-m", "--propagation", "private"] if os.geteuid() == 0 \
        else ["unshare", "-U", "-r", "-m", "--propagation", "private"]
    return [*unshare, "sh", "-c", _SCRIPT, "sh", str(workspace), str(path), *argv]


def start_at_path(workspace: Path, path: Path, argv: Sequence[str], *,
                  env: Mapping[str, str], log: Path | None = None) -> subprocess.Popen[str]:
    """Start `argv` at `path` in its own process group (`stop()` ends all of it); its output
    goes to `log` (one stream), else to a pipe."""
    out = open(log, "w") if log is not None else subprocess.PIPE  # noqa: SIM115
    try:
        return subprocess.Popen(at_path_command(workspace, path, argv), env=dict(env),
                                stdout=out, stderr=subprocess.STDOUT, text=True,
                                start_new_session=True)
    finally:
        if log is not None:
            out.close()  # type: ignore[union-attr]


def run_at_path(workspace: Path, path: Path, argv: Sequence[str], *, env: Mapping[str, str],
                timeout: float = 600) -> subprocess.CompletedProcess[str]:
    """Run `argv` at `path` to its end; stdout and stderr apart."""
    return subprocess.run(at_path_command(workspace, path, argv), env=dict(env),
                          capture_output=True, text=True, timeout=timeout, check=False)


def stop(process: subprocess.Popen[str], sig: int = signal.SIGKILL) -> None:
    """End `process` and everything it started (its process group)."""
    try:
        os.killpg(process.pid, sig)
    except ProcessLookupError:
        pass
    process.wait(timeout=30)
