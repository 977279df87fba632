"""The dependency elements of a package.xml: the tags each format allows and the kinds they
expand to, names, version constraints and conditions, the checks across them (duplicates, a
package depending on itself, redundant tags, groups), and the version constraints a workspace
violates."""

from __future__ import annotations

import re
from collections.abc import Mapping

from lxml import etree

from wsbuild.workspace.manifest_elements import ElementReader
from wsbuild.workspace.model import Dependency, DepKind, VersionConstraint
from wsbuild.workspace.names import (
    DEPENDENCY_NAME_RULE,
    is_valid_dependency_name,
    is_valid_package_name,
    package_name_hint,
)

# Constraint versions stay permissive (bloom writes e.g. "1.9.3-r0"), but never hold spaces,
# quotes or control characters, so messages that quote them stay on one line.
_CONSTRAINT_VERSION = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+~:-]*").fullmatch

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
DEPENDS_BY_FORMAT = {1: _FORMAT1_DEPENDS, 2: _FORMAT2_DEPENDS, 3: _FORMAT3_DEPENDS}
#: Every tag some format defines, to tell "wrong format" (error) from "unknown" (warning).
ALL_FORMAT_TAGS = frozenset(_FORMAT1_DEPENDS) | frozenset(_FORMAT3_DEPENDS) | {"member_of_group"}

_CONSTRAINT_OPS = {
    "version_lt": "lt",
    "version_lte": "lte",
    "version_eq": "eq",
    "version_gte": "gte",
    "version_gt": "gt",
}
_OP_ORDER = {"lt": 0, "lte": 1, "eq": 2, "gte": 3, "gt": 4}

DEPEND_ATTRIBUTES = frozenset(_CONSTRAINT_OPS) | {"condition"}
GROUP_ATTRIBUTES = frozenset({"condition"})

_GROUP_TAGS = frozenset({"group_depend", "member_of_group"})
_DEPEND_IMPLIES: tuple[str, ...] = ("build_depend", "build_export_depend", "exec_depend")
_FORMAT1_TEST_OVERLAP: tuple[str, ...] = ("build_depend", "run_depend")

# One dependency-like element as written, before expansion into Dependency records:
# (tag, name, condition, constraints, line, active).
RawDependency = tuple[str, str, "str | None", tuple[VersionConstraint, ...], int, bool]


def read_dependency(
    reader: ElementReader, element: etree._Element, tag: str, allowed: frozenset[str]
) -> RawDependency:
    """One dependency-like element (`allowed`: its attributes) as written; raises for a bad
    name, version or condition."""
    line = element.sourceline or 1
    # text_of() inlined: this runs for every dependency of every package.
    if len(element):
        reader.text_of(element)
    name = element.text
    name = name.strip() if name else ""
    is_group = tag in _GROUP_TAGS
    if not name:
        example = "rosidl_interface_packages" if is_group else "rclcpp"
        raise reader.error(
            f"empty <{tag}>", line, f"put a name inside, e.g. <{tag}>{example}</{tag}>"
        )
    if is_group:
        # REP 149: group names follow the package naming rules.
        if not is_valid_package_name(name):
            raise reader.error(
                f"invalid group name {name!r} in <{tag}>", line, package_name_hint(name)
            )
    elif not is_valid_dependency_name(name):
        raise reader.error(
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
                    known = " or ".join(repr(k) for k in sorted(allowed))
                    reader.refuse(line, f"unknown attribute {key!r} on <{tag}>",
                                  f"remove it: <{tag}> takes {known}")
            elif key == "condition":
                condition = element.get(key)
            else:
                value = element.get(key, "").strip()
                if not _CONSTRAINT_VERSION(value):
                    problem = f"invalid {key} {value!r}" if value else f"empty {key}"
                    raise reader.error(
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
        if reader.format < 3:
            raise reader.error(
                f"condition attribute on <{tag}> {name!r} needs package format 3 "
                f"(this manifest is format {reader.format})",
                line,
                'declare <package format="3">',
            )
        active = reader.condition(element, condition)
    return (tag, name, condition, constraints, line, active)


def check_dependencies(
    reader: ElementReader, name: str, raws: list[RawDependency], groups: list[RawDependency]
) -> None:
    """The checks across the elements of package `name`: duplicates warn; a package depending
    on itself, tags catkin_pkg calls redundant and a group both depended on and joined raise."""
    by_name: dict[str, list[RawDependency]] = {}
    for raw in raws:
        tag, dep_name, condition, constraints, line, _active = raw
        same_name = by_name.get(dep_name)
        if same_name is None:
            by_name[dep_name] = [raw]
            continue
        for other in same_name:
            if other[0] == tag and other[2] == condition and other[3] == constraints:
                reader.warn(line, f"duplicate <{tag}> on {dep_name!r} (first on line {other[4]})")
                break
        same_name.append(raw)
    for raw in by_name.get(name, ()):
        if raw[0] not in ("conflict", "replace", "group_depend"):
            raise reader.error(
                f"the package {name!r} depends on itself (<{raw[0]}>)",
                raw[4],
                f"remove <{raw[0]}>{name}</{raw[0]}>",
            )
    # catkin_pkg rejects these redundancies, so colcon would not build such a package.
    if reader.format >= 2:
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
                    raise reader.error(
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
                    raise reader.error(
                        f"the package depends on group {dep_name!r} and is a member of it "
                        f"(<member_of_group> on line {members[dep_name]})",
                        line,
                        "remove the <group_depend> or the <member_of_group>",
                    )


def expand_dependencies(
    raws: list[RawDependency], depends: Mapping[str, tuple[DepKind, ...]]
) -> tuple[Dependency, ...]:
    """The Dependency records of the active elements, each (name, kind) once, in order."""
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
    return tuple(dependencies)
