"""package.xml → Package: formats 1–3, the metadata elements, build_type, and the whole read.

`manifest_dependencies` reads the dependency elements, `manifest_elements` holds what every
element reader shares, `names` the naming rules.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Collection, Mapping
from pathlib import Path

from lxml import etree

from wsbuild.errors import ManifestError
from wsbuild.workspace.manifest_dependencies import (
    ALL_FORMAT_TAGS,
    DEPEND_ATTRIBUTES,
    DEPENDS_BY_FORMAT,
    GROUP_ATTRIBUTES,
    RawDependency,
    check_dependencies,
    expand_dependencies,
    read_dependency,
)
from wsbuild.workspace.manifest_elements import ElementReader
from wsbuild.workspace.model import DepKind, Package, Person
from wsbuild.words import close_to
from wsbuild.workspace.names import (
    PACKAGE_NAME_RULE,
    is_valid_package_name,
    package_name_hint,
    suggest_package_name,
)

_VERSION = re.compile(r"[0-9]+\.[0-9]+\.[0-9]+").fullmatch
_CANONICAL_VERSION = re.compile(r"(?:0|[1-9][0-9]*)(?:\.(?:0|[1-9][0-9]*)){2}").fullmatch

_FORMATS = {"1": 1, "2": 2, "3": 3}
#: how close an unknown element must be to a known one to count as its misspelling
_MISSPELT = 0.8
#: ... and to be named as what it may have meant
_NEAR = 0.6
#: the emails catkin_pkg takes (catkin_pkg.package.Person.validate)
_CATKIN_EMAIL = re.compile(r"[-a-zA-Z0-9_%+]+(\.[-a-zA-Z0-9_%+]+)*@[-a-zA-Z0-9%]+"
                           r"(\.[-a-zA-Z0-9%]+)*\.[a-zA-Z]{2,}").fullmatch

_METADATA_TAGS = frozenset(
    {"name", "version", "description", "maintainer", "license", "url", "author", "export"}
)

_ATTRIBUTES: dict[str, frozenset[str]] = {
    "name": frozenset(),
    "version": frozenset({"compatibility"}),
    "description": frozenset(),
    "maintainer": frozenset({"email"}),
    "author": frozenset({"email"}),
    "license": frozenset({"file", "type", "source-files"}),
    "url": frozenset({"type"}),
    "export": frozenset(),
}

_thread_state = threading.local()


def parse_manifest(
    path: Path,
    *,
    environ: Mapping[str, str],
    known_build_types: Collection[str],
    warnings: list[str] | None = None,
) -> Package:
    """Read and validate one package.xml, evaluating REP 149 conditions against `environ`.

    Raises ManifestError (ConditionError for a malformed condition) naming the file, line
    and a fix; appends one-line "<file>:<line>: <message>" warnings to `warnings`.
    """
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ManifestError(
            f"cannot read the package manifest: {exc.strerror or exc}",
            path=path,
            hint="check that the file exists and is readable",
        ) from None
    try:
        root = etree.fromstring(data, _xml_parser())
    except etree.XMLSyntaxError as exc:
        raise ManifestError(
            f"not well-formed XML: {_one_line(str(exc.msg))}",
            path=path,
            line=exc.lineno or 1,
            hint="fix the XML syntax of this package.xml",
        ) from None
    return _Reader(path, environ, warnings).read(root, known_build_types)


def _xml_parser() -> etree.XMLParser:
    # lxml parsers must not be shared between threads; one per thread, created once.
    parser: etree.XMLParser | None = getattr(_thread_state, "parser", None)
    if parser is None:
        parser = etree.XMLParser(
            remove_comments=True,
            remove_pis=True,
            resolve_entities=False,
            no_network=True,
            load_dtd=False,
        )
        _thread_state.parser = parser
    return parser


def _one_line(text: str) -> str:
    return " ".join(text.split())


class _Found:
    """The top-level elements of one manifest, gathered in one walk before any is checked."""

    __slots__ = ("names", "versions", "descriptions", "exports", "maintainers", "licenses",
                 "raws", "groups")

    def __init__(self) -> None:
        self.names: list[etree._Element] = []
        self.versions: list[etree._Element] = []
        self.descriptions: list[etree._Element] = []
        self.exports: list[etree._Element] = []
        self.maintainers: list[Person] = []
        self.licenses: list[str] = []
        self.raws: list[RawDependency] = []
        self.groups: list[RawDependency] = []


class _Reader(ElementReader):
    """Walks one parsed manifest once; errors stop at the first problem."""

    __slots__ = ()

    def read(self, root: etree._Element, known_build_types: Collection[str]) -> Package:
        root_line = self.read_root(root)
        depends = DEPENDS_BY_FORMAT[self.format]
        found = self.collect(root, depends)
        name = self.name(found.names, root_line)
        version = self.version(found.versions, root_line)
        description = self.description(found.descriptions, root_line)
        if not found.maintainers:
            raise self.error(
                "missing <maintainer>",
                root_line,
                'add <maintainer email="you@example.com">Your Name</maintainer> inside <package>',
            )
        if not found.licenses:
            raise self.error(
                "missing <license>",
                root_line,
                "add <license>Apache-2.0</license>, or another SPDX license id, inside <package>",
            )
        check_dependencies(self, name, found.raws, found.groups)
        build_type, other_exports = self.exports(found.exports, root_line, known_build_types)
        members = tuple(dict.fromkeys(raw[1] for raw in found.groups if raw[5]))

        return Package(
            name=name,
            path=self.path.parent,
            build_type=build_type,
            version=version,
            manifest=self.path,
            description=description,
            licenses=tuple(found.licenses),
            maintainers=tuple(found.maintainers),
            dependencies=expand_dependencies(found.raws, depends),
            member_of_groups=members,
            exports=other_exports,
            refused=tuple(self.refused),
        )

    def read_root(self, root: etree._Element) -> int:
        """Check the root element and take its format; returns its line."""
        root_line = root.sourceline or 1
        if root.tag != "package":
            shown = f"<{root.tag}>" if isinstance(root.tag, str) else "not an element"
            raise self.error(
                f"the root element is {shown}, not <package>",
                root_line,
                'a package.xml has exactly one root element <package format="3">',
            )
        format_text = root.get("format")
        if format_text is not None:
            fmt = _FORMATS.get(format_text.strip())
            if fmt is None:
                raise self.error(
                    f"unknown package format {format_text!r}",
                    root_line,
                    'use <package format="3">; formats 1, 2 and 3 exist',
                )
            self.format = fmt
        for key in root.keys():
            if key != "format" and key[0] != "{":
                self.refuse(root_line, f"unknown attribute {key!r} on <package>",
                            "remove it: <package> takes only 'format'")
        return root_line

    def collect(
        self, root: etree._Element, depends: Mapping[str, tuple[DepKind, ...]]
    ) -> _Found:
        """Every top-level element, dependency elements read, metadata gathered unchecked."""
        found = _Found()
        for element in root:
            tag = element.tag
            if tag.__class__ is not str:  # unresolved entity references
                continue
            if tag in depends:
                allowed = GROUP_ATTRIBUTES if tag == "group_depend" else DEPEND_ATTRIBUTES
                found.raws.append(read_dependency(self, element, tag, allowed))
            elif tag in _METADATA_TAGS:
                self.check_attributes(element, _ATTRIBUTES[tag])
                if tag == "name":
                    found.names.append(element)
                elif tag == "version":
                    found.versions.append(element)
                elif tag == "description":
                    found.descriptions.append(element)
                elif tag == "maintainer":
                    found.maintainers.append(self.maintainer(element))
                elif tag == "license":
                    found.licenses.append(self.license(element))
                elif tag == "export":
                    found.exports.append(element)
                else:  # url, author: not part of the model, but still text-only
                    self.text_of(element)
                    if tag == "author":
                        self.check_email(element, element.get("email"))
            elif tag == "member_of_group" and self.format >= 3:
                found.groups.append(read_dependency(self, element, tag, GROUP_ATTRIBUTES))
            elif tag in ALL_FORMAT_TAGS:
                raise self.wrong_format(element, tag)
            else:
                self.unknown_element(element, tag, depends)
        return found

    def unknown_element(self, element: etree._Element, tag: str,
                        depends: Mapping[str, tuple[DepKind, ...]]) -> None:
        """A misspelling of an element this format knows (`<buildtool_dpend>`) is an error: the
        build would go on without it and fail far from the cause. Other unknown elements are
        warnings, as catkin_pkg has them (a tool's own element is no mistake)."""
        known = [*depends, *_METADATA_TAGS, *(("member_of_group",) if self.format >= 3 else ())]
        close = close_to(tag, known, cutoff=_MISSPELT)
        if close:
            raise self.error(f"unknown element <{tag}> (package format {self.format})",
                             element.sourceline, f"did you mean <{close[0]}>?")
        near = close_to(tag, known, cutoff=_NEAR)
        fix = f"did you mean <{near[0]}>? Else remove it" if near else "remove it"
        self.refuse(element.sourceline,
                    f"unknown element <{tag}> (not part of package format {self.format})",
                    f"{fix}, or put a tool's own element inside <export>",
                    f"unknown element <{tag}> ignored (not part of package format {self.format})")

    def wrong_format(self, element: etree._Element, tag: str) -> ManifestError:
        fmt = self.format
        if tag == "run_depend":
            hint = (
                "replace <run_depend> with <exec_depend>, plus <build_export_depend> "
                "if dependents build against it"
            )
        elif fmt == 1:
            hint = (
                f'declare <package format="3"> to use <{tag}>; format 1 only has '
                "build_depend, buildtool_depend, run_depend and test_depend"
            )
        else:
            hint = f'declare <package format="3"> to use <{tag}>'
        return self.error(
            f"<{tag}> is not allowed in package format {fmt}", element.sourceline, hint
        )

    def maintainer(self, element: etree._Element) -> Person:
        name = _one_line(self.text_of(element))
        email = (element.get("email") or "").strip()
        if not email:
            raise self.error(
                f"<maintainer> {name!r} has no email",
                element.sourceline,
                f'write <maintainer email="you@example.com">{name or "Your Name"}</maintainer>',
            )
        self.check_email(element, email)
        return Person(name, email)

    def check_email(self, element: etree._Element, email: str | None) -> None:
        """An email catkin_pkg refuses (`a@b.c`: its domain must end in two letters or more)."""
        if email and not _CATKIN_EMAIL(email):
            self.refuse(element.sourceline, f"invalid email {email!r} of <{element.tag}>",
                        "write a full address, e.g. email=\"you@example.com\"",
                        f"email {email!r} of <{element.tag}> is not an address catkin_pkg "
                        "takes (ament_cmake packages refuse it)")

    def license(self, element: etree._Element) -> str:
        # wsbuild reads `type` and `source-files` (format 4); catkin_pkg refuses them, and
        # `file` before format 3
        for key in element.keys():
            if key in _ATTRIBUTES["license"] and (key != "file" or self.format < 3):
                self.refused.append((element.sourceline or 1,
                                     f"attribute {key!r} on <license>",
                                     "remove it: catkin_pkg takes only <license file=...>, "
                                     "in package format 3"))
        text = self.text_of(element)
        if not text:
            raise self.error(
                "empty <license>",
                element.sourceline,
                "write the license inside, e.g. <license>Apache-2.0</license>",
            )
        return text

    def name(self, names: list[etree._Element], root_line: int) -> str:
        if not names:
            suggestion = suggest_package_name(self.path.parent.name) or "my_package"
            raise self.error(
                "missing <name>", root_line, f"add <name>{suggestion}</name> inside <package>"
            )
        self.single(names, "name")
        name = self.text_of(names[0])
        if not name:
            raise self.error("the package name is empty", names[0].sourceline, PACKAGE_NAME_RULE)
        if not is_valid_package_name(name):
            raise self.error(
                f"invalid package name {name!r}", names[0].sourceline, package_name_hint(name)
            )
        return name

    def version(self, versions: list[etree._Element], root_line: int) -> str:
        if not versions:
            raise self.error(
                "missing <version>", root_line, "add <version>0.0.0</version> inside <package>"
            )
        self.single(versions, "version")
        element = versions[0]
        version = self.text_of(element)
        if not _VERSION(version):
            raise self.error(
                f"invalid version {version!r}",
                element.sourceline,
                "write MAJOR.MINOR.PATCH with digits only, e.g. <version>1.0.0</version>",
            )
        if not _CANONICAL_VERSION(version):
            self.warn(element.sourceline, f"version {version!r} has leading zeros")
        compatibility = element.get("compatibility")
        if compatibility is not None and not _VERSION(compatibility.strip()):
            raise self.error(
                f"invalid compatibility version {compatibility!r}",
                element.sourceline,
                'write MAJOR.MINOR.PATCH with digits only, e.g. compatibility="1.0.0"',
            )
        return version

    def description(self, descriptions: list[etree._Element], root_line: int) -> str:
        if not descriptions:
            raise self.error(
                "missing <description>",
                root_line,
                "add <description>What this package does</description> inside <package>",
            )
        self.single(descriptions, "description")
        # The description may contain XHTML; keep its text on one line.
        text = " ".join("".join(map(str, descriptions[0].itertext())).split())
        if not text:
            raise self.error(
                "empty <description>",
                descriptions[0].sourceline,
                "say in a sentence what the package does",
            )
        return text

    def exports(
        self,
        exports: list[etree._Element],
        root_line: int,
        known_build_types: Collection[str],
    ) -> tuple[str, tuple[tuple[str, str], ...]]:
        self.single(exports, "export")
        build_types: list[tuple[str, int, bool, etree._Element]] = []
        others: list[tuple[str, str]] = []
        export_line = root_line
        if exports:
            export_line = exports[0].sourceline or root_line
            for child in exports[0]:
                tag = child.tag
                if tag.__class__ is not str:
                    continue
                if tag == "build_type":
                    value = self.text_of(child)
                    line = child.sourceline or export_line
                    if not value:
                        raise self.error(
                            "empty <build_type>",
                            line,
                            f"write one of: {_known(known_build_types)}",
                        )
                    condition = child.get("condition")
                    # Evaluate every condition so a malformed one is reported even if unused.
                    active = condition is None or self.condition(child, condition)
                    build_types.append((value, line, active, child))
                else:
                    others.append((tag, (child.text or "").strip()))

        applicable = [entry for entry in build_types if entry[2]]
        if len(applicable) > 1:
            shown = ", ".join(f"{value!r} (line {line})" for value, line, _, _ in applicable)
            raise self.error(
                f"several <build_type> elements apply: {shown}",
                applicable[1][1],
                "keep one <build_type>, or give them conditions that exclude each other",
            )
        if applicable:
            value, line, _, _ = applicable[0]
            if value not in known_build_types:
                raise self.error(
                    f"unknown build type {value!r}",
                    line,
                    f"use one of: {_known(known_build_types)}",
                )
            return value, tuple(others)
        if build_types:
            raise self.error(
                "no <build_type> condition holds in this environment",
                build_types[0][1],
                "add a <build_type> whose condition holds for this $ROS_VERSION/$ROS_DISTRO, "
                "or ignore the package with a COLCON_IGNORE file",
            )
        return self.fallback_build_type(export_line, known_build_types), tuple(others)

    def fallback_build_type(self, line: int, known_build_types: Collection[str]) -> str:
        directory = self.path.parent
        if (directory / "CMakeLists.txt").is_file():
            build_type, reason = "ament_cmake", "CMakeLists.txt"
        elif (directory / "setup.py").is_file():
            build_type, reason = "ament_python", "setup.py"
        else:
            raise self.error(
                "no <build_type> declared and neither CMakeLists.txt nor setup.py "
                "beside package.xml",
                line,
                "add <export><build_type>ament_cmake</build_type></export> inside <package>; "
                f"known build types: {_known(known_build_types)}",
            )
        if build_type not in known_build_types:
            raise self.error(
                f"no <build_type> declared and the fallback {build_type!r} "
                "is not a known build type",
                line,
                f"add <export><build_type>...</build_type></export> with one of: "
                f"{_known(known_build_types)}",
            )
        self.warn(
            line,
            f"no <build_type> declared; assuming {build_type} because {reason} is beside "
            f"package.xml: add <export><build_type>{build_type}</build_type></export>",
        )
        return build_type


def _known(known_build_types: Collection[str]) -> str:
    return ", ".join(sorted(known_build_types)) or "(no build types are installed)"
