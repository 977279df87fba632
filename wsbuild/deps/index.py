"""What the package index pip uses holds: asked through the underlay venv's own pip, so that
its configuration (index URL, find-links, proxies, certificates) applies as it will for the
install. The index's answers (not a timeout or a failing network) are remembered in the user's
cache, a day when the index has the name and an hour when not, per name asked (a
`ros-<distro>-*` name carries its distro) and per index settings, so that a second look at an
unchanged workspace asks nothing; `--refresh` asks again."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import time
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.files import atomic_write, wsbuild_cache_dir

from wsbuild.deps.names import invalid_name, valid_pip_requirement

#: the longest one question to the index may take (pip retries a dead network itself)
QUERY_TIMEOUT = 120.0
#: how long a remembered answer holds: a day when the index has the name, an hour when not
#: (pip cannot always tell a network it did not reach from an index without the name)
ANSWER_TTL = 24 * 3600.0
MISSING_TTL = 3600.0
#: pip's words for a network it did not reach: such an answer is not remembered
_NETWORK_TROUBLE = ("Retrying", "Could not fetch", "ConnectionError", "ProxyError", "SSLError",
                    "timed out", "Max retries")
#: the settings that decide which index pip asks: answers are remembered per combination
_INDEX_SETTINGS = ("PIP_INDEX_URL", "PIP_EXTRA_INDEX_URL", "PIP_FIND_LINKS", "PIP_NO_INDEX",
                   "PIP_CONFIG_FILE")


@dataclass(frozen=True, slots=True)
class IndexAnswer:
    """Whether a distribution is on the index; `detail` is pip's reason when it is not."""

    name: str
    exists: bool
    detail: str = ""
    #: whether the index itself gave it (not a timeout or a network failure pip reported)
    definite: bool = True


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
                           f"the package index did not answer in {QUERY_TIMEOUT:.0f} s",
                           definite=False)
    except OSError as exc:
        return IndexAnswer(name, False, f"cannot run pip: {exc.strerror or exc}", definite=False)
    if done.returncode == 0:
        return IndexAnswer(name, True)
    text = done.stderr + done.stdout
    return IndexAnswer(name, False, error_line(text),
                       definite=not any(word in text for word in _NETWORK_TROUBLE))


@dataclass(slots=True)
class AnswerMemory:
    """The index's definite answers, remembered in one JSON file: {scope: {name: [exists,
    detail, time]}}; a scope is one interpreter with one set of index settings."""

    path: Path
    scope: str
    now: float = field(default_factory=time.time)

    def _fresh(self, entry: object) -> bool:
        if not (isinstance(entry, list) and len(entry) == 3
                and isinstance(entry[2], (int, float))):
            return False
        return 0 <= self.now - entry[2] < (ANSWER_TTL if entry[0] else MISSING_TTL)

    @classmethod
    def for_index(cls, python: Path, environ: Mapping[str, str]) -> AnswerMemory:
        settings = [str(python), *(f"{k}={environ.get(k, '')}" for k in _INDEX_SETTINGS)]
        scope = hashlib.sha256("\n".join(settings).encode()).hexdigest()[:16]
        return cls(wsbuild_cache_dir(environ) / "deps" / "index-answers.json", scope)

    def _read(self) -> dict[str, dict[str, list[object]]]:
        try:
            data = json.loads(self.path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return {}
        return data if isinstance(data, dict) else {}

    def recall(self, names: Iterable[str]) -> dict[str, IndexAnswer]:
        """The remembered, unexpired answers for `names`."""
        known = self._read().get(self.scope, {})
        found: dict[str, IndexAnswer] = {}
        for name in names:
            entry = known.get(name) if isinstance(known, dict) else None
            if self._fresh(entry):
                exists, detail = bool(entry[0]), str(entry[1])  # type: ignore[index]
                if not exists:
                    detail += " (remembered; --refresh asks the index again)"
                found[name] = IndexAnswer(name, exists, detail)
        return found

    def remember(self, answers: Iterable[IndexAnswer]) -> None:
        """Keep the definite ones (there, or not on the index); never fails the look."""
        definite = [a for a in answers if a.definite]
        if not definite:
            return
        data = self._read()
        scope = data.setdefault(self.scope, {})
        for answer in definite:
            scope[answer.name] = [answer.exists, answer.detail, self.now]
        for other in list(data):  # drop what has expired everywhere
            entries = data[other] if isinstance(data[other], dict) else {}
            data[other] = {n: e for n, e in entries.items() if self._fresh(e)}
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(self.path, json.dumps(data, sort_keys=True, indent=0) + "\n")
        except OSError:
            pass  # an unwritable cache only costs the next look its questions


def query(python: Path, names: Iterable[str], environ: Mapping[str, str] | None = None,
          *, memory: AnswerMemory | None = None, refresh: bool = False,
          ) -> dict[str, IndexAnswer]:
    """Ask the index about each name, a few at a time (each is one small HTTP request);
    with `memory`, names answered within its expiry are not asked again (unless `refresh`)."""
    unique = sorted(set(names))
    env = dict(os.environ if environ is None else environ)
    if not unique:
        return {}
    known = {} if memory is None or refresh else memory.recall(unique)
    ask = [n for n in unique if n not in known]
    if not ask:
        return known
    with ThreadPoolExecutor(max_workers=min(8, len(ask))) as pool:
        asked = {answer.name: answer
                 for answer in pool.map(lambda n: query_one(python, n, env), ask)}
    if memory is not None:
        memory.remember(asked.values())
    return {**known, **asked}
