"""What the package index pip uses holds: asked through the underlay venv's own pip, so that
its configuration (index URL, find-links, proxies, certificates) applies as it will for the
install."""

from __future__ import annotations

import os
import subprocess
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from wsbuild.deps.names import invalid_name, valid_pip_requirement

#: the longest one question to the index may take (pip retries a dead network itself)
QUERY_TIMEOUT = 120.0


@dataclass(frozen=True, slots=True)
class IndexAnswer:
    """Whether a distribution is on the index; `detail` is pip's reason when it is not."""

    name: str
    exists: bool
    detail: str = ""


def pip_command(python: Path) -> list[str]:
    """The underlay venv's own pip."""
    return [str(python), "-m", "pip"]


def pip_environment(environ: Mapping[str, str]) -> dict[str, str]:
    """The environment pip runs in: the user's, without a version-check chatter."""
    env = {k: v for k, v in environ.items() if k != "PYTHONHOME"}
    env.setdefault("PIP_DISABLE_PIP_VERSION_CHECK", "1")
    return env


def error_line(output: str) -> str:
    """pip's (or apt-get's) last `ERROR:`/`E:` line, else its last non-empty line."""
    lines = [line.strip() for line in output.splitlines() if line.strip()]
    for line in reversed(lines):
        if line.startswith(("ERROR:", "E: ")):
            return line
    return lines[-1] if lines else "no output"


def query_one(python: Path, name: str, environ: Mapping[str, str]) -> IndexAnswer:
    """`pip index versions -- NAME`: one request for the project's page on the index."""
    if not valid_pip_requirement(name):
        return IndexAnswer(name, False, invalid_name("pip", name))
    command = [*pip_command(python), "index", "versions", "--", name]
    try:
        done = subprocess.run(command, capture_output=True, text=True, check=False,
                              env=pip_environment(environ), timeout=QUERY_TIMEOUT)
    except subprocess.TimeoutExpired:
        return IndexAnswer(name, False,
                           f"the package index did not answer in {QUERY_TIMEOUT:.0f} s")
    except OSError as exc:
        return IndexAnswer(name, False, f"cannot run pip: {exc.strerror or exc}")
    if done.returncode == 0:
        return IndexAnswer(name, True)
    return IndexAnswer(name, False, error_line(done.stderr + done.stdout))


def query(python: Path, names: Iterable[str], environ: Mapping[str, str] | None = None,
          ) -> dict[str, IndexAnswer]:
    """Ask the index about each name, a few at a time (each is one small HTTP request)."""
    unique = sorted(set(names))
    env = dict(os.environ if environ is None else environ)
    if not unique:
        return {}
    with ThreadPoolExecutor(max_workers=min(8, len(unique))) as pool:
        answers = pool.map(lambda n: query_one(python, n, env), unique)
        return {answer.name: answer for answer in answers}
