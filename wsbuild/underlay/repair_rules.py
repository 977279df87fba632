"""The repair rules: each mends one defect a wheel-venv ROS underlay's files carry from the
wheels' build machine (`/opt/python/cp3XX-cp3XX` in a manylinux container).

* `share/<msgs>/cmake/export_<msgs>__rosidl_generator_pyExport.cmake` puts
  `/opt/python/cp311-cp311/include/python3.11` and
  `/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include` into
  `INTERFACE_INCLUDE_DIRECTORIES`.  CMake refuses to generate any project that links
  those targets ("Imported target ... includes non-existent path"), which is every
  `rosidl_generate_interfaces()` depending on a message package.
* `share/fastrtps/cmake/fastrtps-shared-targets.cmake` links `/usr/lib64/libtinyxml2.so`
  (`make: No rule to make target '/usr/lib64/libtinyxml2.so'` for anything linking rcl),
  although `libfastrtps.so` already carries its own bundled tinyxml2.
* `share/fastrtps/cmake/fastrtps-config.cmake` does `find_package(OpenSSL REQUIRED)` and
  links `OpenSSL::SSL`, so every rcl consumer needs the host's OpenSSL headers, although
  `libfastrtps.so` carries its own bundled OpenSSL.
* `share/ament_index/resource_index/parent_prefix_path/*` names `/opt/python/cp311-cp311`
  as the parent prefix (harmless for CMake, rewritten for consistency).

A rule takes a file's text and returns the new text and one `Edit` per changed line.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from wsbuild.underlay.detect import VenvPython
from wsbuild.words import shorten
from wsbuild.patterns import lazy

_OPT_PYTHON = lazy(
    r"/opt/python/cp(?P<major>\d)(?P<minor>\d+)-cp\d+[a-z]*(?P<rest>(?:/[A-Za-z0-9_.+\-/]*)?)"
)
_INCLUDE_REST = lazy(r"/include/python\d+\.\d+[a-z]*(?P<tail>(?:/.*)?)$")
_SITE_REST = lazy(r"/lib/python\d+\.\d+/(?:site|dist)-packages(?P<tail>(?:/.*)?)$")
_BIN_PYTHON_REST = lazy(r"/bin/python[0-9.]*$")
_LINK_LIBRARIES = lazy(r'(?P<head>^\s*INTERFACE_LINK_LIBRARIES\s+")(?P<value>[^"]*)(?P<tail>".*)$')
# libraries of the manylinux (AlmaLinux) build host; Debian/Ubuntu never use lib64
_HOST_LIBRARY = lazy(r"^/usr/(?:local/)?lib64/[^;\s\"$<>]+\.(?:so|a)(?:\.[0-9.]+)?$")
_OPENSSL_REQUIRED = lazy(r"find_package\(\s*OpenSSL\s+REQUIRED\s*\)")
_OPENSSL_GENEX = "$<$<BOOL:1>:OpenSSL::SSL"
_OPENSSL_GENEX_ESCAPED = r"\$<\$<BOOL:1>:OpenSSL::SSL"


@dataclass(frozen=True)
class Edit:
    """One changed line: its number (1-based), the old line (stripped, shortened), the fix."""

    line: int
    text: str
    fix: str


# A rule takes the file text and returns (new text, edits).
Rule = Callable[[str], "tuple[str, list[Edit]]"]


def _opt_python_rule(prefix: Path, python: VenvPython) -> Rule:
    """`/opt/python/cp3XX-cp3XX/...` -> the venv's include dir / site-packages / python / prefix."""

    def target(match: re.Match[str]) -> str:
        rest = match["rest"]
        m = _INCLUDE_REST.match(rest)
        if m:
            return str(python.include_dir) + m["tail"]
        m = _SITE_REST.match(rest)
        if m:
            tail = m["tail"]
            new = str(python.site_packages) + tail
            if "/numpy/_core/include" in tail and not os.path.isdir(new):
                legacy = new.replace("/numpy/_core/include", "/numpy/core/include")
                if os.path.isdir(legacy):  # numpy < 2
                    new = legacy
            return new
        if _BIN_PYTHON_REST.match(rest):
            return str(python.executable)
        return str(prefix) + rest

    def rule(text: str) -> tuple[str, list[Edit]]:
        if "/opt/python/" not in text:
            return text, []
        edits: list[Edit] = []
        out: list[str] = []
        for number, line in enumerate(text.splitlines(keepends=True), 1):
            if "/opt/python/" in line:
                replaced = _OPT_PYTHON.sub(target, line)
                if replaced != line:
                    pairs = dict.fromkeys((m.group(0), target(m)) for m in _OPT_PYTHON.finditer(line))
                    fix = "; ".join(f"replace {old} with {new}" for old, new in pairs)
                    edits.append(Edit(number, shorten(line.strip()), fix))
                    line = replaced
            out.append(line)
        return "".join(out), edits

    return rule


def _host_library_rule(text: str) -> tuple[str, list[Edit]]:
    """Drop `INTERFACE_LINK_LIBRARIES` entries naming build-host `/usr/lib64` libraries that
    do not exist here.

    (`/usr/lib64/libtinyxml2.so` from the manylinux build host; `libfastrtps.so` already
    needs its bundled copy, so consumers lose nothing.)
    """
    if "INTERFACE_LINK_LIBRARIES" not in text:
        return text, []
    edits: list[Edit] = []
    out: list[str] = []
    for number, line in enumerate(text.splitlines(keepends=True), 1):
        m = _LINK_LIBRARIES.match(line.rstrip("\n"))
        if m:
            items = m["value"].split(";")
            gone = [i for i in items if _HOST_LIBRARY.match(i) and not os.path.exists(i)]
            if gone:
                kept = [i for i in items if i not in gone]
                newline = m["head"] + ";".join(kept) + m["tail"] + ("\n" if line.endswith("\n") else "")
                edits.append(
                    Edit(number, shorten(line.strip()), f"drop {', '.join(gone)} (not on this machine)")
                )
                line = newline
        out.append(line)
    return "".join(out), edits


def _openssl_rule(text: str) -> tuple[str, list[Edit]]:
    """fastrtps: make the host OpenSSL optional (the wheel bundles its own libssl/libcrypto)."""
    edits: list[Edit] = []
    out: list[str] = []
    for number, line in enumerate(text.splitlines(keepends=True), 1):
        new = line
        if _OPENSSL_REQUIRED.search(new):
            new = _OPENSSL_REQUIRED.sub("find_package(OpenSSL QUIET)", new)
        if _OPENSSL_GENEX_ESCAPED in new:
            new = new.replace(_OPENSSL_GENEX_ESCAPED, r"\$<\$<TARGET_EXISTS:OpenSSL::SSL>:OpenSSL::SSL")
        elif _OPENSSL_GENEX in new:
            new = new.replace(_OPENSSL_GENEX, "$<$<TARGET_EXISTS:OpenSSL::SSL>:OpenSSL::SSL")
        if new != line:
            edits.append(
                Edit(
                    number,
                    shorten(line.strip()),
                    "make OpenSSL optional: find_package(OpenSSL QUIET), link OpenSSL::SSL only if found",
                )
            )
        out.append(new)
    return "".join(out), edits


def rules_for(path: Path, prefix: Path, python: VenvPython) -> list[Rule]:
    rules: list[Rule] = [_opt_python_rule(prefix, python)]
    if path.suffix == ".cmake":
        rules.append(_host_library_rule)
        if path.parent == prefix / "share" / "fastrtps" / "cmake":
            rules.append(_openssl_rule)
    return rules


#: what some rule looks for: a file holding none of these is left alone without decoding it
QUICK_TOKENS = (b"/opt/python/", b"/lib64/", b"OpenSSL")
