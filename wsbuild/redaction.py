"""Credentials kept out of everything wsbuild writes: the user:password or token of a URL."""

from __future__ import annotations

import re

#: what stands in for the credentials of a URL in what wsbuild writes
HIDDEN = "***"
#: a URL's scheme, then its user information (user:password, or a token) up to the `@`
_CREDENTIALS = re.compile(r"(?P<scheme>\b[A-Za-z][A-Za-z0-9+.-]*://)[^\s/?#@'\"<>]+@")
_CREDENTIALS_BYTES = re.compile(_CREDENTIALS.pattern.encode())


def redact(text: str) -> str:
    """`text` with the credentials of every URL in it replaced by `***`
    (`http://ci:secret@host/` → `http://***@host/`); text without one comes back as it is."""
    if "@" not in text or "://" not in text:
        return text
    return _CREDENTIALS.sub(rf"\g<scheme>{HIDDEN}@", text)


def redact_bytes(data: bytes) -> bytes:
    """`redact` for a line of a program's output as it is written to a log."""
    if b"@" not in data or b"://" not in data:
        return data
    return _CREDENTIALS_BYTES.sub(rb"\g<scheme>" + HIDDEN.encode() + rb"@", data)
