"""`pkg create`'s request and its checks: package names (REP 144, and usable as a Python module
and a C++ namespace), node and library identifiers, dependencies, one-line texts, the e-mail and
the license."""

from __future__ import annotations

import dataclasses
import keyword
import re
import sys
from collections.abc import Collection, Iterable
from dataclasses import dataclass
from pathlib import Path

from wsbuild.create.licenses import NO_LICENSE, canonical_license, find_license
from wsbuild.errors import WsbuildError
from wsbuild.workspace.names import (
    DEPENDENCY_NAME_RULE,
    PACKAGE_NAME_RULE,
    is_valid_dependency_name,
    is_valid_package_name,
    suggest_package_name,
)
from wsbuild.patterns import lazy

DEFAULT_BUILD_TYPE = "ament_cmake"
DEFAULT_DESCRIPTION = "TODO: Package description"
PACKAGE_FORMATS = (2, 3)

_IDENTIFIER = lazy(r"[A-Za-z][A-Za-z0-9_]*")
EMAIL = re.compile(r"[^@\s<>\"'&]+@[^@\s<>\"'&]+")
CONTROL_CHARACTER = lazy(r"[\x00-\x1f\x7f]")

# Names become C++ namespaces and macros (libraries, generated message code), so keywords
# of C++ are as unusable as those of Python.
CPP_KEYWORDS = frozenset(
    "alignas alignof and and_eq asm auto bitand bitor bool break case catch char char8_t "
    "char16_t char32_t class compl concept const consteval constexpr constinit const_cast "
    "continue co_await co_return co_yield decltype default delete do double dynamic_cast else "
    "enum explicit export extern false float for friend goto if inline int long mutable "
    "namespace new noexcept not not_eq nullptr operator or or_eq private protected public "
    "register reinterpret_cast requires return short signed sizeof static static_assert "
    "static_cast struct switch template this thread_local throw true try typedef typeid "
    "typename union unsigned using virtual void volatile wchar_t while xor xor_eq".split()
)


class PackageCreateError(WsbuildError):
    """The requested package cannot be created (bad name, existing directory, ...)."""


@dataclass(frozen=True, slots=True)
class PackageRequest:
    """Everything `pkg create` needs, validated by `create_package`."""

    name: str
    destination: Path
    maintainer_name: str
    maintainer_email: str
    build_type: str = DEFAULT_BUILD_TYPE
    dependencies: tuple[str, ...] = ()
    node_name: str | None = None
    library_name: str | None = None
    launch: bool = False
    description: str = DEFAULT_DESCRIPTION
    license: str = NO_LICENSE
    package_format: int = 3
    #: the year in the LICENSE file (None: this year)
    year: int | None = None


def check_package_name(name: str) -> None:
    """REP 144, and a name usable as a Python module and C++ namespace (ROS generates both).

    Raises PackageCreateError with a suggestion.
    """
    if not is_valid_package_name(name):
        raise PackageCreateError(f"invalid package name {name!r}", hint=_name_hint(name))
    if "__" in name or len(name) < 2:
        raise PackageCreateError(
            f"invalid package name {name!r}",
            hint="at least two characters, no consecutive underscores; " + _name_hint(name))
    if keyword.iskeyword(name) or name in CPP_KEYWORDS:
        raise PackageCreateError(
            f"the package name {name!r} is a Python or C++ keyword",
            hint="the name becomes a Python module and a C++ namespace; e.g. "
                 f"'{name}_pkg'")
    if name == "test":
        raise PackageCreateError(
            "the package name 'test' is reserved",
            hint="a package's tests live in its test/ folder, and Python's standard library "
                 "has a `test` package; e.g. 'my_test'")
    if name in sys.stdlib_module_names:
        raise PackageCreateError(
            f"the package name {name!r} is a module of the Python standard library",
            hint=f"`import {name}` would find one of the two (a Python package and the "
                 f"generated message modules are imported by package name); e.g. 'my_{name}'")


def _name_hint(name: str) -> str:
    # stricter than package.xml's suggestion: REP 144 also asks for two characters at least
    candidate = suggest_package_name(name)
    ok = candidate is not None and len(candidate) >= 2 and candidate != name
    return f"{PACKAGE_NAME_RULE}, e.g. {candidate!r}" if ok else PACKAGE_NAME_RULE


def check_identifier(name: str, option: str) -> None:
    """Node and library names: identifiers valid in Python, C and C++, and as ROS node names."""
    if not _IDENTIFIER.fullmatch(name):
        raise PackageCreateError(
            f"invalid {option} {name!r}",
            hint="it becomes a Python module, a C++ target and a ROS node name: a letter, "
                 "then letters, digits or underscores")
    if keyword.iskeyword(name) or name in CPP_KEYWORDS:
        raise PackageCreateError(f"invalid {option} {name!r}: a Python or C++ keyword",
                                 hint=f"e.g. '{name}_node'")


def _check_text(value: str, option: str) -> str:
    value = value.strip()
    if not value:
        raise PackageCreateError(f"{option} is empty",
                                 hint=f"give {option} a value or leave it out")
    if CONTROL_CHARACTER.search(value):
        raise PackageCreateError(f"{option} contains a line break or control character",
                                 hint="write it on one line")
    return value


def _check_dependencies(name: str, dependencies: Iterable[str]) -> tuple[str, ...]:
    result: set[str] = set()
    for dep in dependencies:
        if not is_valid_dependency_name(dep):
            raise PackageCreateError(f"invalid dependency name {dep!r}", hint=DEPENDENCY_NAME_RULE)
        if dep == name:
            raise PackageCreateError(f"the package {name!r} cannot depend on itself",
                                     hint=f"remove {name} from --dependencies")
        result.add(dep)
    return tuple(sorted(result))


@dataclass(frozen=True, slots=True)
class CheckedRequest:
    """A request with its texts trimmed, its dependencies sorted and its license spelled as
    SPDX does, and what the user should be told about it."""

    request: PackageRequest
    notes: tuple[str, ...]


def check_request(request: PackageRequest, build_types: Collection[str]) -> CheckedRequest:
    """Check every option of `request` (`build_types`: those with a template folder); raises
    PackageCreateError saying what to write instead."""
    if request.build_type not in build_types:
        raise PackageCreateError(f"unknown build type {request.build_type!r}",
                                 hint=f"use one of: {', '.join(sorted(build_types))}")
    check_package_name(request.name)
    if request.node_name is not None:
        check_identifier(request.node_name, "--node-name")
    if request.library_name is not None:
        check_identifier(request.library_name, "--library-name")
        if request.library_name == request.node_name:
            raise PackageCreateError(
                f"--node-name and --library-name are both {request.node_name!r}",
                hint=f"name them differently, e.g. --node-name {request.node_name}_node")
    if request.launch and request.node_name is None:
        raise PackageCreateError("--launch needs --node-name",
                                 hint="the launch file and config/params.yaml are for that node")
    if request.package_format not in PACKAGE_FORMATS:
        raise PackageCreateError(f"unknown package format {request.package_format}",
                                 hint="use --package-format 3 (or 2)")
    dependencies = _check_dependencies(request.name, request.dependencies)
    description = _check_text(request.description, "--description")
    maintainer_name = _check_text(request.maintainer_name, "--maintainer-name")
    maintainer_email = _check_text(request.maintainer_email, "--maintainer-email")
    if not EMAIL.fullmatch(maintainer_email):
        raise PackageCreateError(f"invalid maintainer email {maintainer_email!r}",
                                 hint="write it like you@example.com")
    license_text, problem = canonical_license(_check_text(request.license, "--license"))
    if problem is not None:
        raise PackageCreateError(f"{license_text!r} is not an SPDX license id",
                                 hint=f"use {problem} (--license '?' lists those with a "
                                      "LICENSE text)")
    notes: list[str] = []
    if license_text == NO_LICENSE:
        notes.append(f"no license chosen: package.xml says {NO_LICENSE!r}; choose one with "
                     "--license (--license '?' lists them)")
    elif find_license(license_text) is None:
        notes.append(f"no LICENSE text for {license_text!r}: add a LICENSE file yourself")
    checked = dataclasses.replace(
        request, dependencies=dependencies, description=description,
        maintainer_name=maintainer_name, maintainer_email=maintainer_email, license=license_text)
    return CheckedRequest(checked, tuple(notes))
