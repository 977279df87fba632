"""package.xml → Package: formats 1–3, REP 149 conditions, groups, build_type and validation.

Longer than most modules on purpose: one reader walks the whole REP 140/149 element set, and
splitting it by element would spread one schema over several files.
"""

from __future__ import annotations

import operator
import re
import threading
from collections.abc import Callable, Collection, Mapping
from pathlib import Path

from lxml import etree
from packaging.version import InvalidVersion, Version

from wsbuild.errors import ConditionError, ManifestError
from wsbuild.workspace.condition import evaluate_condition
from wsbuild.workspace.model import (
    Dependency,
    DepKind,
    Package,
    Person,
    VersionConstraint,
)

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
# Constraint versions stay permissive (bloom writes e.g. "1.9.3-r0"), but never hold spaces,
# quotes or control characters, so messages that quote them stay on one line.
_CONSTRAINT_VERSION = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+~:-]*").fullmatch
_VERSION = re.compile(r"[0-9]+\.[0-9]+\.[0-9]+").fullmatch
_CANONICAL_VERSION = re.compile(r"(?:0|[1-9][0-9]*)(?:\.(?:0|[1-9][0-9]*)){2}").fullmatch
_NOT_NAME_CHARS = re.compile(r"[^a-z0-9_]+")
_UNDERSCORES = re.compile(r"__+")

_FORMATS = {"1": 1, "2": 2, "3": 3}

_B, _BT = DepKind.BUILD, DepKind.BUILDTOOL
_BE, _BTE = DepKind.BUILD_EXPORT, DepKind.BUILDTOOL_EXPORT
_E, _T, _D, _G = DepKind.EXEC, DepKind.TEST, DepKind.DOC, DepKind.GROUP

# Dependency-like tags per format and the kinds they expand to, as colcon-ros reads them
# through catkin_pkg. conflict/replace only matter to packaging and expand to nothing.
_FORMAT1_DEPENDS: dict[str, tuple[DepKind, ...]] = {
    "build_depend": (_B,),
    "buildtool_depend": (_BT,),
    "run_depend": (_BE, _E),
    "test_depend": (_T,),
    "conflict": (),
    "replace": (),
}
_FORMAT2_DEPENDS: dict[str, tuple[DepKind, ...]] = {
    "build_depend": (_B,),
    "buildtool_depend": (_BT,),
    "build_export_depend": (_BE,),
    "buildtool_export_depend": (_BTE,),
    "exec_depend": (_E,),
    "depend": (_B, _BE, _E),
    "doc_depend": (_D,),
    "test_depend": (_T,),
    "conflict": (),
    "replace": (),
}
_FORMAT3_DEPENDS = {**_FORMAT2_DEPENDS, "group_depend": (_G,)}
_DEPENDS_BY_FORMAT = {1: _FORMAT1_DEPENDS, 2: _FORMAT2_DEPENDS, 3: _FORMAT3_DEPENDS}

_METADATA_TAGS = frozenset(
    {"name", "version", "description", "maintainer", "license", "url", "author", "export"}
)
#: Every tag some format defines, to tell "wrong format" (error) from "unknown" (warning).
_ALL_FORMAT_TAGS = frozenset(_FORMAT1_DEPENDS) | frozenset(_FORMAT3_DEPENDS) | {"member_of_group"}

_CONSTRAINT_OPS = {
    "version_lt": "lt",
    "version_lte": "lte",
    "version_eq": "eq",
    "version_gte": "gte",
    "version_gt": "gt",
}
_OP_ORDER = {"lt": 0, "lte": 1, "eq": 2, "gte": 3, "gt": 4}
_COMPARE: dict[str, Callable[[Version, Version], bool]] = {
    "lt": operator.lt,
    "lte": operator.le,
    "eq": operator.eq,
    "gte": operator.ge,
    "gt": operator.gt,
}
_OP_SYMBOLS = {"lt": "<", "lte": "<=", "eq": "==", "gte": ">=", "gt": ">"}

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
_DEPEND_ATTRIBUTES = frozenset(_CONSTRAINT_OPS) | {"condition"}
_GROUP_ATTRIBUTES = frozenset({"condition"})

_GROUP_TAGS = frozenset({"group_depend", "member_of_group"})
_DEPEND_IMPLIES: tuple[str, ...] = ("build_depend", "build_export_depend", "exec_depend")
_FORMAT1_TEST_OVERLAP: tuple[str, ...] = ("build_depend", "run_depend")

_thread_state = threading.local()


def is_valid_package_name(name: str) -> bool:
    """True if `name` follows REP 144 (see PACKAGE_NAME_RULE)."""
    return _PACKAGE_NAME(name) is not None


def is_valid_dependency_name(name: str) -> bool:
    """True if `name` is a safe dependency name (see DEPENDENCY_NAME_RULE)."""
    return _DEPENDENCY_NAME(name) is not None


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


def check_version_constraints(packages: Mapping[str, Package]) -> list[str]:
    """One line per `version_*` constraint that a workspace package's version violates."""
    messages: list[str] = []
    for name in sorted(packages):
        package = packages[name]
        where = package.manifest if package.manifest is not None else package.path / "package.xml"
        reported: set[tuple[str, int | None, VersionConstraint]] = set()
        for dep in package.dependencies:
            target = packages.get(dep.name)
            if target is None or not dep.constraints or dep.name == name:
                continue
            for constraint in dep.constraints:
                # `depend` expands to three Dependency records with the same constraint.
                key = (dep.name, dep.line, constraint)
                if key in reported:
                    continue
                reported.add(key)
                problem = _violation(constraint, target.version)
                if problem is None:
                    continue
                location = f"{where}:{dep.line}" if dep.line else f"{where}"
                messages.append(
                    f"{location}: {name!r} requires {dep.name!r} "
                    f'version_{constraint.op}="{constraint.version}" '
                    f"({_OP_SYMBOLS[constraint.op]} {constraint.version}) {problem} "
                    f"{dep.name!r} {target.version}"
                )
    return messages


def _violation(constraint: VersionConstraint, actual: str) -> str | None:
    try:
        wanted = Version(constraint.version)
    except InvalidVersion:
        return "but the constraint is not a valid version, so it cannot be compared with"
    try:
        have = Version(actual)
    except InvalidVersion:
        return "but cannot be compared with the invalid version of"
    return None if _COMPARE[constraint.op](have, wanted) else "but the workspace has"


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


def _suggest_name(name: str) -> str | None:
    candidate = _UNDERSCORES.sub("_", _NOT_NAME_CHARS.sub("_", name.lower()))
    candidate = candidate.lstrip("0123456789_").rstrip("_")
    return candidate if _PACKAGE_NAME(candidate) else None


def _name_hint(name: str) -> str:
    suggestion = _suggest_name(name)
    return f"{PACKAGE_NAME_RULE}, e.g. {suggestion!r}" if suggestion else PACKAGE_NAME_RULE


# One dependency-like element as written, before expansion into Dependency records:
# (tag, name, condition, constraints, line, active).
_Raw = tuple[str, str, "str | None", tuple[VersionConstraint, ...], int, bool]


class _Reader:
    """Walks one parsed manifest once; errors stop at the first problem."""

    __slots__ = ("path", "environ", "warnings", "format")

    def __init__(
        self, path: Path, environ: Mapping[str, str], warnings: list[str] | None
    ) -> None:
        self.path = path
        self.environ = environ
        self.warnings = warnings
        self.format = 1

    def warn(self, line: int | None, message: str) -> None:
        if self.warnings is not None:
            self.warnings.append(f"{self.path}:{line or 1}: {message}")

    def error(self, message: str, line: int | None, hint: str) -> ManifestError:
        return ManifestError(message, path=self.path, line=line or 1, hint=hint)

    def condition(self, element: etree._Element, expr: str) -> bool:
        try:
            return evaluate_condition(expr, self.environ)
        except ConditionError as exc:
            raise ConditionError(
                f"<{element.tag}> has an invalid condition: {exc.message}",
                path=self.path,
                line=element.sourceline or 1,
                hint=exc.hint,
            ) from None

    def text_of(self, element: etree._Element) -> str:
        if len(element):
            child = element[0]
            found = f"<{child.tag}>" if isinstance(child.tag, str) else "markup"
            raise self.error(
                f"<{element.tag}> must contain only text, found {found}",
                element.sourceline,
                f"remove the markup inside <{element.tag}>",
            )
        text = element.text
        return text.strip() if text else ""

    def check_attributes(self, element: etree._Element, allowed: frozenset[str]) -> None:
        for key in element.keys():
            if key not in allowed and key[0] != "{":  # namespaced (xsi:...) attributes are fine
                self.warn(
                    element.sourceline, f"unknown attribute {key!r} on <{element.tag}> ignored"
                )

    def read(self, root: etree._Element, known_build_types: Collection[str]) -> Package:
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
                self.warn(root_line, f"unknown attribute {key!r} on <package> ignored")

        depends = _DEPENDS_BY_FORMAT[self.format]
        names: list[etree._Element] = []
        versions: list[etree._Element] = []
        descriptions: list[etree._Element] = []
        exports: list[etree._Element] = []
        maintainers: list[Person] = []
        licenses: list[str] = []
        raws: list[_Raw] = []
        groups: list[_Raw] = []

        for element in root:
            tag = element.tag
            if tag.__class__ is not str:  # unresolved entity references
                continue
            if tag in depends:
                allowed = _GROUP_ATTRIBUTES if tag == "group_depend" else _DEPEND_ATTRIBUTES
                raws.append(self.dependency(element, tag, allowed))
            elif tag in _METADATA_TAGS:
                self.check_attributes(element, _ATTRIBUTES[tag])
                if tag == "name":
                    names.append(element)
                elif tag == "version":
                    versions.append(element)
                elif tag == "description":
                    descriptions.append(element)
                elif tag == "maintainer":
                    maintainers.append(self.maintainer(element))
                elif tag == "license":
                    licenses.append(self.license(element))
                elif tag == "export":
                    exports.append(element)
                else:  # url, author: not part of the model, but still text-only
                    self.text_of(element)
            elif tag == "member_of_group" and self.format >= 3:
                groups.append(self.dependency(element, tag, _GROUP_ATTRIBUTES))
            elif tag in _ALL_FORMAT_TAGS:
                raise self.wrong_format(element, tag)
            else:
                self.warn(
                    element.sourceline,
                    f"unknown element <{tag}> ignored (not part of package format {self.format})",
                )

        name = self.name(names, root_line)
        version = self.version(versions, root_line)
        description = self.description(descriptions, root_line)
        if not maintainers:
            raise self.error(
                "missing <maintainer>",
                root_line,
                'add <maintainer email="you@example.com">Your Name</maintainer> inside <package>',
            )
        if not licenses:
            raise self.error(
                "missing <license>",
                root_line,
                "add <license>Apache-2.0</license>, or another SPDX license id, inside <package>",
            )
        self.check_dependencies(name, raws, groups)
        build_type, other_exports = self.exports(exports, root_line, known_build_types)

        dependencies: list[Dependency] = []
        seen: set[tuple[str, str]] = set()
        for tag, dep_name, _condition, constraints, line, active in raws:
            if not active:
                continue
            for kind in depends[tag]:
                # Keyed by the enum's string value: hashing an Enum member is slow in Python.
                seen_key = (dep_name, kind._value_)
                if seen_key not in seen:
                    seen.add(seen_key)
                    dependencies.append(Dependency(dep_name, kind, constraints, line))
        members = tuple(dict.fromkeys(raw[1] for raw in groups if raw[5]))

        return Package(
            name=name,
            path=self.path.parent,
            build_type=build_type,
            version=version,
            manifest=self.path,
            description=description,
            licenses=tuple(licenses),
            maintainers=tuple(maintainers),
            dependencies=tuple(dependencies),
            member_of_groups=members,
            exports=other_exports,
        )

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

    def dependency(self, element: etree._Element, tag: str, allowed: frozenset[str]) -> _Raw:
        line = element.sourceline or 1
        # text_of() inlined: this runs for every dependency of every package.
        if len(element):
            self.text_of(element)
        name = element.text
        name = name.strip() if name else ""
        is_group = tag in _GROUP_TAGS
        if not name:
            example = "rosidl_interface_packages" if is_group else "rclcpp"
            raise self.error(
                f"empty <{tag}>", line, f"put a name inside, e.g. <{tag}>{example}</{tag}>"
            )
        if is_group:
            # REP 149: group names follow the package naming rules.
            if not _PACKAGE_NAME(name):
                raise self.error(f"invalid group name {name!r} in <{tag}>", line, _name_hint(name))
        elif not _DEPENDENCY_NAME(name):
            raise self.error(
                f"invalid dependency name {name!r} in <{tag}>", line, DEPENDENCY_NAME_RULE
            )
        condition: str | None = None
        constraints: tuple[VersionConstraint, ...] = ()
        keys = element.keys()
        if keys:
            found: list[VersionConstraint] = []
            for key in keys:
                if key not in allowed:
                    if key[0] != "{":
                        self.warn(line, f"unknown attribute {key!r} on <{tag}> ignored")
                elif key == "condition":
                    condition = element.get(key)
                else:
                    value = element.get(key, "").strip()
                    if not _CONSTRAINT_VERSION(value):
                        problem = f"invalid {key} {value!r}" if value else f"empty {key}"
                        raise self.error(
                            f"{problem} on <{tag}> {name!r}",
                            line,
                            f'give a version, e.g. {key}="1.0.0", or remove the attribute',
                        )
                    found.append(VersionConstraint(_CONSTRAINT_OPS[key], value))
            if found:
                found.sort(key=lambda c: _OP_ORDER[c.op])
                constraints = tuple(found)
        active = True
        if condition is not None:
            if self.format < 3:
                raise self.error(
                    f"condition attribute on <{tag}> {name!r} needs package format 3 "
                    f"(this manifest is format {self.format})",
                    line,
                    'declare <package format="3">',
                )
            active = self.condition(element, condition)
        return (tag, name, condition, constraints, line, active)

    def maintainer(self, element: etree._Element) -> Person:
        name = _one_line(self.text_of(element))
        email = (element.get("email") or "").strip()
        if not email:
            raise self.error(
                f"<maintainer> {name!r} has no email",
                element.sourceline,
                f'write <maintainer email="you@example.com">{name or "Your Name"}</maintainer>',
            )
        return Person(name, email)

    def license(self, element: etree._Element) -> str:
        text = self.text_of(element)
        if not text:
            raise self.error(
                "empty <license>",
                element.sourceline,
                "write the license inside, e.g. <license>Apache-2.0</license>",
            )
        return text

    def single(self, elements: list[etree._Element], tag: str) -> None:
        if len(elements) > 1:
            raise self.error(
                f"more than one <{tag}> (the first is on line {elements[0].sourceline})",
                elements[1].sourceline,
                f"keep exactly one <{tag}>",
            )

    def name(self, names: list[etree._Element], root_line: int) -> str:
        if not names:
            suggestion = _suggest_name(self.path.parent.name) or "my_package"
            raise self.error(
                "missing <name>", root_line, f"add <name>{suggestion}</name> inside <package>"
            )
        self.single(names, "name")
        name = self.text_of(names[0])
        if not name:
            raise self.error("the package name is empty", names[0].sourceline, PACKAGE_NAME_RULE)
        if not _PACKAGE_NAME(name):
            raise self.error(
                f"invalid package name {name!r}", names[0].sourceline, _name_hint(name)
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

    def check_dependencies(self, name: str, raws: list[_Raw], groups: list[_Raw]) -> None:
        by_name: dict[str, list[_Raw]] = {}
        for raw in raws:
            tag, dep_name, condition, constraints, line, _active = raw
            same_name = by_name.get(dep_name)
            if same_name is None:
                by_name[dep_name] = [raw]
                continue
            for other in same_name:
                if other[0] == tag and other[2] == condition and other[3] == constraints:
                    self.warn(line, f"duplicate <{tag}> on {dep_name!r} (first on line {other[4]})")
                    break
            same_name.append(raw)
        for raw in by_name.get(name, ()):
            if raw[0] not in ("conflict", "replace", "group_depend"):
                raise self.error(
                    f"the package {name!r} depends on itself (<{raw[0]}>)",
                    raw[4],
                    f"remove <{raw[0]}>{name}</{raw[0]}>",
                )
        # catkin_pkg rejects these redundancies, so colcon would not build such a package.
        if self.format >= 2:
            general, specific = "depend", _DEPEND_IMPLIES
            why = "<depend> already means build_depend + build_export_depend + exec_depend"
        else:
            general, specific = "test_depend", _FORMAT1_TEST_OVERLAP
            why = "in format 1 build and run dependencies are available to tests"
        for same_name in by_name.values():
            if len(same_name) < 2:
                continue
            for raw in same_name:
                if raw[0] != general:
                    continue
                for other in same_name:
                    if other[0] in specific and other[2:4] == raw[2:4]:
                        first, second = sorted((raw[4], other[4]))
                        raise self.error(
                            f"<{general}> on {raw[1]!r} is redundant with <{other[0]}> "
                            f"(lines {first} and {second})",
                            second,
                            f"remove the <{other[0]}>; {why}",
                        )
        if groups:
            members = {raw[1]: raw[4] for raw in groups}
            for same_name in by_name.values():
                for tag, dep_name, _condition, _constraints, line, _active in same_name:
                    if tag == "group_depend" and dep_name in members:
                        raise self.error(
                            f"the package depends on group {dep_name!r} and is a member of it "
                            f"(<member_of_group> on line {members[dep_name]})",
                            line,
                            "remove the <group_depend> or the <member_of_group>",
                        )

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
