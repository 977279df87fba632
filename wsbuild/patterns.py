"""A module's regular expressions, compiled when first used: a command runs few of the modules'
patterns it imports (a no-op build uses about a tenth of the ones on its path), and compiling
them all at import took more of its time than any one module."""

from __future__ import annotations

import re

TYPE_CHECKING = False
if TYPE_CHECKING:  # (typing is off the replayed no-op's path)
    from typing import Any


class LazyPattern:
    """`re.compile(pattern, flags)`, done at the first use of any of its methods or attributes
    (`match`, `search`, `sub`, `pattern`, ...), which it then answers as the compiled pattern
    does. Only these are forwarded: pass `.compiled` where an `re.Pattern` is needed."""

    __slots__ = ("_pattern", "_flags", "_compiled")

    def __init__(self, pattern: str, flags: int = 0) -> None:
        self._pattern = pattern
        self._flags = flags
        self._compiled: re.Pattern[str] | None = None

    @property
    def compiled(self) -> re.Pattern[str]:
        compiled = self._compiled
        if compiled is None:
            compiled = self._compiled = re.compile(self._pattern, self._flags)
        return compiled

    def __getattr__(self, name: str) -> Any:
        return getattr(self.compiled, name)

    def __repr__(self) -> str:
        return f"lazy({self._pattern!r})"


def lazy(pattern: str, flags: int = 0) -> LazyPattern:
    """`re.compile`, compiled at first use (a bad pattern raises there, and at once under the
    test suite's check that every module's patterns compile)."""
    return LazyPattern(pattern, flags)
