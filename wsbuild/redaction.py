"""Secrets kept out of everything wsbuild writes (logs, `command.log`, reports, timings, the
screen): the user:password or token of any URL, and the values of the secrets wsbuild knows
of in this run, wherever they appear, a build step's output included:

- the environment's variables whose names say they hold one (`*_TOKEN`, `*_SECRET`,
  `*PASSWORD*`, `*_API_KEY`, `*CREDENTIALS*`, …; `remember_environment`), at least
  `MIN_SECRET_LENGTH` characters long;
- the build cache's credentials (its URL's password, `WSBUILD_CACHE_TOKEN`, the `~/.netrc`
  password wsbuild sends to it; `remember`).

A secret wsbuild cannot know of (one a step reads from a file and prints, under a name that
says nothing) is written as the step printed it: the build's logs are the step's own output.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable, Mapping

from wsbuild.patterns import lazy

#: what stands in for a secret in what wsbuild writes
HIDDEN = "***"
#: shorter values are not hidden (a `1` or `true` would be hidden everywhere)
MIN_SECRET_LENGTH = 8
#: a URL's scheme, then its user information (user:password, or a token) up to the `@`
_CREDENTIALS = lazy(r"(?P<scheme>\b[A-Za-z][A-Za-z0-9+.-]*://)[^\s/?#@'\"<>]+@")
_CREDENTIALS_BYTES = lazy(_CREDENTIALS.pattern.encode())
#: a variable whose name says it holds a secret: one of these words between underscores ...
_SECRET_WORDS = frozenset({"TOKEN", "TOKENS", "SECRET", "SECRETS", "PASSWORD", "PASSWD",
                           "PASSPHRASE", "CREDENTIAL", "CREDENTIALS", "APIKEY", "PAT"})
#: ... or a key that is one
_SECRET_KEY = lazy(r"(^|_)(API|ACCESS|PRIVATE|SECRET|SIGNING|ENCRYPTION)_KEY($|_)")

_lock = threading.Lock()
_known: frozenset[str] = frozenset()
_known_bytes: tuple[bytes, ...] = ()


def secret_name(name: str) -> bool:
    """Whether an environment variable's name says it holds a secret."""
    upper = name.upper()
    return bool(_SECRET_WORDS & set(upper.split("_"))) or bool(_SECRET_KEY.search(upper))


def remember(values: Iterable[str]) -> None:
    """Hide these values too (a credential wsbuild was given or read) from now on."""
    global _known, _known_bytes
    fresh = {v for v in values if v and len(v) >= MIN_SECRET_LENGTH}
    with _lock:
        if fresh <= _known:
            return
        _known = _known | fresh
        # the longest first: a secret holding another is hidden whole
        _known_bytes = tuple(sorted((v.encode() for v in _known), key=len, reverse=True))


def remember_environment(environ: Mapping[str, str]) -> None:
    """Hide the values of the environment's variables whose names say they are secrets."""
    remember(value for name, value in environ.items() if secret_name(name))


def redact(text: str) -> str:
    """`text` with the credentials of every URL in it replaced by `***`
    (`http://ci:secret@host/` → `http://***@host/`), and every known secret; text without one
    comes back as it is."""
    for secret in sorted(_known, key=len, reverse=True):
        if secret in text:
            text = text.replace(secret, HIDDEN)
    if "@" not in text or "://" not in text:
        return text
    return _CREDENTIALS.sub(rf"\g<scheme>{HIDDEN}@", text)


def redact_bytes(data: bytes) -> bytes:
    """`redact` for a line of a program's output as it is written to a log."""
    for secret in _known_bytes:
        if secret in data:
            data = data.replace(secret, HIDDEN.encode())
    if b"@" not in data or b"://" not in data:
        return data
    return _CREDENTIALS_BYTES.sub(rb"\g<scheme>" + HIDDEN.encode() + rb"@", data)
