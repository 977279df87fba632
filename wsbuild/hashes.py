"""The hashes wsbuild digests with, taken where importing them costs least: importing hashlib
loads OpenSSL (3 ms of a no-op), yet its blake2b is CPython's own `_blake2`, taken from there
directly. sha256 of a short text (a generated file's name) comes from CPython's own module
too; a stream (a file's content) is digested by OpenSSL's, the fastest on large files, so
hashlib is imported at the first one, which a no-op whose files kept their signatures never
digests. Both give the same digests as hashlib's."""

from __future__ import annotations

TYPE_CHECKING = False  # (typing itself not imported: `wsbuild --version` imports this)
try:
    from _blake2 import blake2b
except ImportError:  # another Python than CPython
    from hashlib import blake2b

try:
    from _sha2 import sha256 as _own_sha256  # CPython ≥ 3.12
except ImportError:
    try:
        from _sha256 import sha256 as _own_sha256  # CPython 3.11
    except ImportError:
        _own_sha256 = None

if TYPE_CHECKING:
    from hashlib import _Hash

__all__ = ["blake2b", "sha256", "sha256_stream"]


def sha256(data: bytes) -> _Hash:
    """hashlib.sha256(data) of a short `data`, without loading OpenSSL."""
    if _own_sha256 is not None:
        return _own_sha256(data)  # type: ignore[no-any-return]
    import hashlib

    return hashlib.sha256(data)


def sha256_stream() -> _Hash:
    """hashlib.sha256(), to be fed a large content piece by piece."""
    import hashlib

    return hashlib.sha256()
