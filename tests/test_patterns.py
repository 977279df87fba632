"""wsbuild/patterns.py: the modules' regular expressions, compiled at first use."""

from __future__ import annotations

import importlib
import pkgutil
import re

import wsbuild
from wsbuild.patterns import LazyPattern, lazy


def test_a_lazy_pattern_answers_as_the_compiled_one_and_compiles_once() -> None:
    pattern = lazy(r"^(\w+)=(\d+)$", re.MULTILINE)
    assert pattern._compiled is None  # nothing compiled at import
    text = "a=1\nb=x\nc=3"
    assert [m.groups() for m in pattern.finditer(text)] == [("a", "1"), ("c", "3")]
    assert pattern.sub(r"\1", text) == re.sub(r"^(\w+)=(\d+)$", r"\1", text, flags=re.MULTILINE)
    assert pattern.pattern == r"^(\w+)=(\d+)$" and pattern.flags & re.MULTILINE
    compiled = pattern.compiled
    assert pattern.match("z=9") is not None and pattern.compiled is compiled


def test_every_module_pattern_compiles() -> None:
    """A bad pattern fails here rather than at the first command that happens to use it."""
    found = 0
    for info in pkgutil.walk_packages(wsbuild.__path__, "wsbuild."):
        if info.name.startswith("wsbuild.templates") or info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for value in vars(module).values():
            if isinstance(value, LazyPattern):
                assert isinstance(value.compiled, re.Pattern), f"{info.name}: {value!r}"
                found += 1
    assert found >= 60  # the modules' patterns are lazy (a sample would not be)
