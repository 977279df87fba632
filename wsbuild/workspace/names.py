"""Package and dependency names: the rules (REP 144 for packages), their checks and a suggested
fix for a name that breaks them."""

from __future__ import annotations

import re

from wsbuild.patterns import lazy

PACKAGE_NAME_RULE = (
    "a package name starts with a lowercase letter and contains only lowercase letters, "
    "digits and underscores (REP 144)"
)
DEPENDENCY_NAME_RULE = (
    "a dependency is a package name or rosdep key: it starts with a letter or digit and "
    "contains only letters, digits and the characters _ . + -"
)

_PACKAGE_NAME = re.compile(r"[a-z][a-z0-9_]*").fullmatch
# Wide enough for rosdep keys (python3-numpy, libgstreamer0.10-dev, libstdc++6), narrow enough
# that a name can never be a path, an option or shell syntax.
_DEPENDENCY_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]*").fullmatch
_NOT_NAME_CHARS = lazy(r"[^a-z0-9_]+")
_UNDERSCORES = lazy(r"__+")


def is_valid_package_name(name: str) -> bool:
    """True if `name` follows REP 144 (see PACKAGE_NAME_RULE)."""
    return _PACKAGE_NAME(name) is not None


def is_valid_dependency_name(name: str) -> bool:
    """True if `name` is a safe dependency name (see DEPENDENCY_NAME_RULE)."""
    return _DEPENDENCY_NAME(name) is not None


def suggest_package_name(name: str) -> str | None:
    """A valid package name close to `name` (lowercased, runs of other characters made one
    underscore), or None when nothing is left."""
    candidate = _UNDERSCORES.sub("_", _NOT_NAME_CHARS.sub("_", name.lower()))
    candidate = candidate.lstrip("0123456789_").rstrip("_")
    return candidate if _PACKAGE_NAME(candidate) else None


def package_name_hint(name: str) -> str:
    """The rule, with a suggestion when there is one."""
    suggestion = suggest_package_name(name)
    return f"{PACKAGE_NAME_RULE}, e.g. {suggestion!r}" if suggestion else PACKAGE_NAME_RULE
