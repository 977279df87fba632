"""The compiled methods of wsbuild's dataclasses, kept between runs as Python keeps a module's
bytecode.

The standard library's `dataclasses` writes the source of each method it adds to a class
(`__init__`, `__repr__`, `__eq__`, `__hash__`, a frozen class's `__setattr__` and
`__delattr__`) and compiles it, every time a module defines a dataclass: about a hundred
dataclasses lie on a no-op build's path, and compiling their methods took a third of its
time (docs/benchmarks.md). What is compiled depends only on the source text and the
interpreter, so `keep()` hands `dataclasses` (its one call of `exec`, found among its module's
names before the builtins) the code compiled from the same text in an earlier run: the same
function results, with the same globals and locals. Source not seen before is compiled as
before, and the file is written again when the process ends.

The file lives beside wsbuild's bytecode (`wsbuild/__pycache__/dataclasses.<interpreter
tag>.marshal`, one per interpreter, for the installed version of wsbuild: an upgrade
reinstalls the directory). It only remembers: it is keyed by the digest of each source text,
so a stale or missing entry costs a compile, never another result. Nothing is written where
Python writes no bytecode (`PYTHONDONTWRITEBYTECODE`, a directory not writable), and the file
is readable by its owner only."""

from __future__ import annotations

import builtins
import marshal
import os
import sys
from types import CodeType

from wsbuild.hashes import blake2b

#: at most this many entries are kept (those this process used first): the file stays small
#: while wsbuild changes under a developer
LIMIT = 4096

#: digest of a source text -> its code, as marshal data until first used (unmarshalling a few
#: hundred code objects one by one takes a tenth of one load of them all: 2 ms against 24)
_codes: dict[bytes, bytes] = {}
_used: set[bytes] = set()
_new = False
#: source texts compiled in this process (not found kept)
compiled = 0
_file: str | None = None


def _digest(text: str) -> bytes:
    return blake2b(text.encode(), digest_size=16).digest()


def _unpacked(packed: bytes | None) -> CodeType | None:
    if packed is None:
        return None
    try:
        code = marshal.loads(packed)
    except (EOFError, ValueError, TypeError):
        return None  # damaged: compiled again
    return code if type(code) is CodeType else None


def _exec(source: object, globals: dict[str, object] | None = None,
          locals: dict[str, object] | None = None) -> None:
    """`exec` as `dataclasses` calls it, with the kept code of a source text seen before."""
    global _new, compiled
    if isinstance(source, str):
        key = _digest(source)
        code = _unpacked(_codes.get(key))
        if code is None:
            code = compile(source, "<string>", "exec")
            _codes[key] = marshal.dumps(code)
            _new = True
            compiled += 1
        _used.add(key)
        source = code
    builtins.exec(source, globals, locals)  # type: ignore[arg-type]


def path() -> str | None:
    """The file of this interpreter (None: it keeps no bytecode's cache tag)."""
    tag = sys.implementation.cache_tag
    if tag is None:
        return None
    return os.path.join(os.path.dirname(__file__), "__pycache__", f"dataclasses.{tag}.marshal")


def keep(at: str | None = None) -> None:
    """Give `dataclasses` the kept code from now on; write what was new at the process's end
    (`at`: another file than `path()`'s)."""
    global _file
    import dataclasses

    if _file is not None or getattr(dataclasses, "exec", None) is not None:
        return
    _file = at or path()
    if _file is None:
        return
    try:
        with open(_file, "rb") as kept:
            loaded = marshal.load(kept)
        if isinstance(loaded, dict):
            _codes.update((k, v) for k, v in loaded.items()
                          if type(k) is bytes and type(v) is bytes)
    except (OSError, EOFError, ValueError, TypeError):
        pass  # none yet, unreadable, or written by another interpreter: compiled as before
    dataclasses.exec = _exec  # type: ignore[attr-defined]
    if not sys.dont_write_bytecode:
        import atexit

        atexit.register(_write)


def _write() -> None:
    """Write the kept code when this process compiled something new (atomically: another
    wsbuild may read it meanwhile)."""
    if not _new or _file is None:
        return
    from pathlib import Path

    from wsbuild.files import atomic_write  # lazy: off `--version`

    # copies taken at once (a daemon thread may still define a class while the process ends)
    codes, used = dict(_codes), list(_used)
    kept = {key: codes[key] for key in used if key in codes}
    for key, code in codes.items():
        if len(kept) >= LIMIT:
            break
        kept.setdefault(key, code)
    try:
        os.makedirs(os.path.dirname(_file), exist_ok=True)
        atomic_write(Path(_file), marshal.dumps(kept), mode=0o600)
    except OSError:
        pass  # where Python could not write bytecode either: compiled again next time
