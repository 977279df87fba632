"""The names wsbuild hands to installers: a PEP 508 requirement for pip, a Debian package name
for apt-get. Anything else (a key like `python3--h`, which would become pip's `-h`) never
reaches a command line; the commands also put the names after `--`."""

from __future__ import annotations


from packaging.requirements import InvalidRequirement, Requirement

from wsbuild.patterns import lazy

#: Debian policy 5.6.1: lowercase letters, digits, `+`, `-`, `.`; at least two characters,
#: starting with a letter or digit (an optional `:arch` qualifier as apt-get takes it)
_DEBIAN_PACKAGE = lazy(r"^[a-z0-9][a-z0-9+.-]+(:[a-z0-9][a-z0-9-]*)?$")


def valid_pip_requirement(text: str) -> bool:
    """A PEP 508 requirement by name (`pyserial`, `foo>=1.2`), not a URL, option or path."""
    if not text or text[0] in "-./":
        return False
    try:
        requirement = Requirement(text)
    except InvalidRequirement:
        return False
    return requirement.url is None


def valid_debian_package(text: str) -> bool:
    """A Debian package name apt-get can take (`libfoo-dev`, `g++`, `libc6:amd64`)."""
    return _DEBIAN_PACKAGE.match(text) is not None


def invalid_name(installer: str, text: str) -> str:
    """Why `text` is never handed to `installer` (for a plan's unresolved keys)."""
    what = "a PEP 508 requirement" if installer == "pip" else "a Debian package name"
    return f"{text!r} is not {what}, so wsbuild does not hand it to {installer}"
