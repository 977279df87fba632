"""package.xml parsing: formats 1–3, conditions, build types, constraints and clear errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from wsbuild.errors import ConditionError, ManifestError
from wsbuild.workspace.manifest import parse_manifest
from wsbuild.workspace.versions import check_version_constraints
from wsbuild.workspace.names import (
    DEPENDENCY_NAME_RULE,
    PACKAGE_NAME_RULE,
    is_valid_dependency_name,
    is_valid_package_name,
)
from wsbuild.workspace.model import DepCategory, Dependency, DepKind, Package, Person, VersionConstraint

KNOWN = frozenset({"ament_cmake", "ament_python", "cmake", "python"})
BAD_MANIFESTS = Path(__file__).parent / "data" / "bad_manifests"

HEADER = """\
<?xml version="1.0"?>
<?xml-model href="http://download.ros.org/schema/package_format{fmt}.xsd"
  schematypens="http://www.w3.org/2001/XMLSchema"?>
<package format="{fmt}">
  <name>{name}</name>
  <version>1.2.3</version>
  <description>A test package</description>
  <maintainer email="dev@example.com">Dev Eloper</maintainer>
  <license>Apache-2.0</license>
"""
EXPORT = """\
  <export>
    <build_type>ament_cmake</build_type>
  </export>
"""


def manifest(fmt: int, body: str = "", *, name: str = "pkg", export: str = EXPORT) -> str:
    return HEADER.format(fmt=fmt, name=name) + body + export + "</package>\n"


def write(tmp_path: Path, text: str, *, folder: str = "pkg", files: tuple[str, ...] = ()) -> Path:
    directory = tmp_path / folder
    directory.mkdir(parents=True, exist_ok=True)
    for name in files:
        (directory / name).write_text("")
    path = directory / "package.xml"
    path.write_text(text)
    return path


def parse(path: Path, environ: dict[str, str] | None = None,
          warnings: list[str] | None = None) -> Package:
    return parse_manifest(path, environ=environ or {}, known_build_types=KNOWN, warnings=warnings)


def kinds(package: Package) -> set[tuple[str, DepKind]]:
    return {(d.name, d.kind) for d in package.dependencies}


def line_of(path: Path, needle: str) -> int:
    for number, text in enumerate(path.read_text().splitlines(), start=1):
        if needle in text:
            return number
    raise AssertionError(needle)


# --- good manifests -----------------------------------------------------------------------


def test_format_2_metadata_and_every_dependency_kind(tmp_path: Path) -> None:
    body = """\
  <url type="website">https://example.com</url>
  <author email="a@example.com">An Author</author>
  <license>BSD-3-Clause</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_export_depend>ament_cmake_core</buildtool_export_depend>
  <build_depend>b_only</build_depend>
  <build_export_depend>be_only</build_export_depend>
  <exec_depend>e_only</exec_depend>
  <depend>rclcpp</depend>
  <test_depend>ament_lint_auto</test_depend>
  <doc_depend>doxygen</doc_depend>
  <conflict>old_thing</conflict>
  <replace>older_thing</replace>
"""
    path = write(tmp_path, manifest(2, body, name="talker"))
    package = parse(path)

    assert package.name == "talker"
    assert package.path == path.parent
    assert package.manifest == path
    assert package.version == "1.2.3"
    assert package.build_type == "ament_cmake"
    assert package.description == "A test package"
    assert package.licenses == ("Apache-2.0", "BSD-3-Clause")
    assert package.maintainers == (Person("Dev Eloper", "dev@example.com"),)
    assert kinds(package) == {
        ("ament_cmake", DepKind.BUILDTOOL),
        ("ament_cmake_core", DepKind.BUILDTOOL_EXPORT),
        ("b_only", DepKind.BUILD),
        ("be_only", DepKind.BUILD_EXPORT),
        ("e_only", DepKind.EXEC),
        ("rclcpp", DepKind.BUILD),
        ("rclcpp", DepKind.BUILD_EXPORT),
        ("rclcpp", DepKind.EXEC),
        ("ament_lint_auto", DepKind.TEST),
        ("doxygen", DepKind.DOC),
    }
    # conflict/replace matter to binary packaging only.
    assert not {"old_thing", "older_thing"} & {d.name for d in package.dependencies}
    # The colcon categories.
    assert package.dependency_names(DepCategory.BUILD) == {"ament_cmake", "b_only", "rclcpp"}
    assert package.dependency_names(DepCategory.RUN) == {
        "ament_cmake_core", "be_only", "e_only", "rclcpp"}
    assert package.dependency_names(DepCategory.TEST) == {"ament_lint_auto"}
    # Every record points at its line; <depend> expands to three records on one line.
    rclcpp_lines = {d.line for d in package.dependencies if d.name == "rclcpp"}
    assert rclcpp_lines == {line_of(path, "<depend>rclcpp")}


def test_format_1_run_depend_expands_to_build_export_and_exec(tmp_path: Path) -> None:
    body = """\
  <buildtool_depend>catkin_tools_like</buildtool_depend>
  <build_depend>roscpp</build_depend>
  <run_depend>rospy</run_depend>
  <test_depend>rostest</test_depend>
"""
    path = write(tmp_path, manifest(1, body).replace(' format="1"', ""))  # no attribute = format 1
    package = parse(path)
    assert kinds(package) == {
        ("catkin_tools_like", DepKind.BUILDTOOL),
        ("roscpp", DepKind.BUILD),
        ("rospy", DepKind.BUILD_EXPORT),
        ("rospy", DepKind.EXEC),
        ("rostest", DepKind.TEST),
    }
    assert package.dependency_names(DepCategory.RUN) == {"rospy"}


def test_format_3_groups_conditions_and_exports(tmp_path: Path) -> None:
    body = """\
  <depend condition="$ROS_VERSION == 2">rclcpp</depend>
  <depend condition="$ROS_VERSION == 1">roscpp</depend>
  <exec_depend condition="$ROS_PYTHON_VERSION == 3">python3-numpy</exec_depend>
  <exec_depend condition="$ROS_PYTHON_VERSION == 2">python-numpy</exec_depend>
  <test_depend condition="$ROS_DISTRO != humble and ($ROS_VERSION == 2 or $ROS_VERSION == 3)">
    ament_cmake_pytest
  </test_depend>
  <group_depend>rosidl_interface_packages</group_depend>
  <group_depend condition="$ROS_VERSION == 1">message_generators</group_depend>
  <member_of_group>rosidl_interface_packages_extra</member_of_group>
  <member_of_group condition="$ROS_VERSION == 1">ros1_group</member_of_group>
"""
    export = """\
  <export>
    <build_type>ament_cmake</build_type>
    <architecture_independent/>
    <deprecated>
      Use new_pkg instead.
    </deprecated>
    <rviz plugin="${prefix}/plugins.xml"/>
  </export>
"""
    path = write(tmp_path, manifest(3, body, export=export))

    ros2 = parse(path)  # unset variables: ROS_VERSION=2, ROS_DISTRO=jazzy, ROS_PYTHON_VERSION=3
    assert {d.name for d in ros2.dependencies} == {
        "rclcpp", "python3-numpy", "ament_cmake_pytest", "rosidl_interface_packages"}
    assert ros2.group_names() == {"rosidl_interface_packages"}
    # Groups are not ordinary dependency names until the graph expands them.
    assert "rosidl_interface_packages" not in ros2.dependency_names(DepCategory.BUILD)
    assert ros2.member_of_groups == ("rosidl_interface_packages_extra",)
    assert ros2.exports == (
        ("architecture_independent", ""),
        ("deprecated", "Use new_pkg instead."),
        ("rviz", ""),
    )

    ros1 = parse(path, {"ROS_VERSION": "1", "ROS_PYTHON_VERSION": "2", "ROS_DISTRO": "noetic"})
    assert {d.name for d in ros1.dependencies} == {
        "roscpp", "python-numpy", "rosidl_interface_packages", "message_generators"}
    assert ros1.member_of_groups == ("rosidl_interface_packages_extra", "ros1_group")

    humble = parse(path, {"ROS_DISTRO": "humble"})
    assert "ament_cmake_pytest" not in {d.name for d in humble.dependencies}


def test_description_with_markup_becomes_one_line(tmp_path: Path) -> None:
    text = manifest(3).replace(
        "<description>A test package</description>",
        "<description>\n    A <b>bold</b>\n    package.\n  </description>",
    )
    assert parse(write(tmp_path, text)).description == "A bold package."


def test_comments_and_namespaced_attributes_are_ignored(tmp_path: Path) -> None:
    text = manifest(3, "  <!-- <depend>commented_out</depend> -->\n  <depend>real</depend>\n")
    text = text.replace(
        '<package format="3">',
        '<package format="3" xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"'
        ' xsi:noNamespaceSchemaLocation="http://download.ros.org/schema/package_format3.xsd">',
    )
    warnings: list[str] = []
    package = parse(write(tmp_path, text), warnings=warnings)
    assert {d.name for d in package.dependencies} == {"real"}
    assert warnings == []


def test_dependency_names_accept_rosdep_keys(tmp_path: Path) -> None:
    keys = ["python3-numpy", "libgstreamer0.10-dev", "libstdc++6", "Eigen3", "qtbase5-dev"]
    body = "".join(f"  <exec_depend>{key}</exec_depend>\n" for key in keys)
    package = parse(write(tmp_path, manifest(3, body)))
    assert [d.name for d in package.dependencies] == keys


# --- build types ----------------------------------------------------------------------------


def test_build_type_with_conditions_picks_the_true_one(tmp_path: Path) -> None:
    export = """\
  <export>
    <build_type condition="$ROS_VERSION == 1">catkin</build_type>
    <build_type condition="$ROS_VERSION == 2 and $ROS_DISTRO != humble">ament_python</build_type>
    <build_type condition="$ROS_VERSION == 2 and $ROS_DISTRO == humble">ament_cmake</build_type>
  </export>
"""
    path = write(tmp_path, manifest(3, export=export))
    assert parse(path).build_type == "ament_python"
    assert parse(path, {"ROS_DISTRO": "humble"}).build_type == "ament_cmake"
    # catkin is not a known build type, but it is only reported when it is the one that applies.
    with pytest.raises(ManifestError, match="unknown build type 'catkin'"):
        parse(path, {"ROS_VERSION": "1"})


def test_several_applicable_build_types_are_an_error(tmp_path: Path) -> None:
    export = """\
  <export>
    <build_type>ament_cmake</build_type>
    <build_type condition="$ROS_VERSION == 2">ament_python</build_type>
  </export>
"""
    path = write(tmp_path, manifest(3, export=export))
    with pytest.raises(ManifestError, match="several <build_type> elements apply"):
        parse(path)
    assert parse(path, {"ROS_VERSION": "1"}).build_type == "ament_cmake"


def test_unknown_build_type_names_the_known_ones(tmp_path: Path) -> None:
    export = "  <export><build_type>ament_rust</build_type></export>\n"
    path = write(tmp_path, manifest(3, export=export))
    with pytest.raises(ManifestError) as info:
        parse(path)
    assert "unknown build type 'ament_rust'" in str(info.value)
    assert info.value.hint == "use one of: ament_cmake, ament_python, cmake, python"
    # The caller decides which build types exist.
    package = parse_manifest(path, environ={}, known_build_types={"ament_rust"})
    assert package.build_type == "ament_rust"


@pytest.mark.parametrize(
    ("beside", "expected"),
    [(("CMakeLists.txt",), "ament_cmake"), (("setup.py",), "ament_python"),
     (("CMakeLists.txt", "setup.py"), "ament_cmake")],
)
def test_missing_build_type_falls_back_with_a_warning(
    tmp_path: Path, beside: tuple[str, ...], expected: str
) -> None:
    path = write(tmp_path, manifest(3, export=""), files=beside)
    warnings: list[str] = []
    package = parse(path, warnings=warnings)
    assert package.build_type == expected
    assert len(warnings) == 1
    warning = warnings[0]
    assert warning.startswith(f"{path}:{line_of(path, '<package')}: ")
    assert f"<export><build_type>{expected}</build_type></export>" in warning
    assert "\n" not in warning


def test_missing_build_type_warning_points_at_the_export_element(tmp_path: Path) -> None:
    export = "  <export>\n    <architecture_independent/>\n  </export>\n"
    path = write(tmp_path, manifest(3, export=export), files=("setup.py",))
    warnings: list[str] = []
    assert parse(path, warnings=warnings).build_type == "ament_python"
    assert warnings[0].startswith(f"{path}:{line_of(path, '<export>')}: ")


def test_missing_build_type_without_build_files_is_an_error(tmp_path: Path) -> None:
    path = write(tmp_path, manifest(3, export=""))
    with pytest.raises(ManifestError) as info:
        parse(path)
    assert "<export><build_type>ament_cmake</build_type></export>" in str(info.value)


def test_fallback_must_be_a_known_build_type(tmp_path: Path) -> None:
    path = write(tmp_path, manifest(3, export=""), files=("setup.py",))
    with pytest.raises(ManifestError, match="'ament_python' is not a known build type"):
        parse_manifest(path, environ={}, known_build_types={"cmake"})


# --- warnings -------------------------------------------------------------------------------


def test_unknown_elements_and_attributes_are_warnings(tmp_path: Path) -> None:
    body = """\
  <favourite_colour>blue</favourite_colour>
  <exec_depend versoin_gte="1.0.0">rclpy</exec_depend>
"""
    path = write(tmp_path, manifest(3, body))
    warnings: list[str] = []
    package = parse(path, warnings=warnings)
    assert {d.name for d in package.dependencies} == {"rclpy"}
    assert warnings == [
        f"{path}:{line_of(path, 'favourite')}: unknown element <favourite_colour> ignored "
        "(not part of package format 3)",
        f"{path}:{line_of(path, 'versoin')}: "
        "unknown attribute 'versoin_gte' on <exec_depend> ignored",
    ]


@pytest.mark.parametrize(("fmt", "written", "meant"), [
    (3, "buildtool_dpend", "buildtool_depend"),
    (3, "exec_depnd", "exec_depend"),
    (2, "maintaner", "maintainer"),
    (3, "licence", "license"),
])
def test_a_misspelt_known_element_is_an_error_naming_the_line_and_the_element_meant(
        tmp_path: Path, fmt: int, written: str, meant: str) -> None:
    """The build would go on without it and fail far away (CMake's 20 lines for a missing
    <buildtool_depend>): the error says where and what was meant."""
    path = write(tmp_path, manifest(fmt, f"  <{written}>ament_cmake</{written}>\n"))
    with pytest.raises(ManifestError) as raised:
        parse(path, warnings=[])
    assert str(raised.value) == (f"{path}:{line_of(path, written)}: unknown element <{written}> "
                                 f"(package format {fmt}) (did you mean <{meant}>?)")


def test_what_catkin_pkg_refuses_is_kept_with_its_line_and_fix(tmp_path: Path) -> None:
    """What wsbuild reads past but catkin_pkg (ament_cmake's reader of package.xml) refuses:
    an unknown element (with what it may have meant), an unknown attribute, an email
    without a two-letter domain, a <license> attribute of format 4."""
    body = """\
  <favourite_colour>blue</favourite_colour>
  <deps>rclpy</deps>
  <author email="a@b.c">Someone</author>
  <exec_depend versoin_gte="1.0.0">rclpy</exec_depend>
"""
    path = write(tmp_path, manifest(3, body).replace("<license>", '<license type="spdx">'))
    package = parse(path, warnings=[])
    assert package.refused == (
        (line_of(path, "<license"), "attribute 'type' on <license>",
         "remove it: catkin_pkg takes only <license file=...>, in package format 3"),
        (line_of(path, "favourite"), "unknown element <favourite_colour> (not part of package "
         "format 3)", "remove it, or put a tool's own element inside <export>"),
        (line_of(path, "<deps>"), "unknown element <deps> (not part of package format 3)",
         "did you mean <depend>? Else remove it, or put a tool's own element inside <export>"),
        (line_of(path, "a@b.c"), "invalid email 'a@b.c' of <author>",
         'write a full address, e.g. email="you@example.com"'),
        (line_of(path, "versoin"), "unknown attribute 'versoin_gte' on <exec_depend>",
         "remove it: <exec_depend> takes 'condition' or 'version_eq' or 'version_gt' or "
         "'version_gte' or 'version_lt' or 'version_lte'"),
    )
    assert parse(write(tmp_path, manifest(3), folder="fine"), warnings=[]).refused == ()


def test_warnings_are_optional(tmp_path: Path) -> None:
    path = write(tmp_path, manifest(3, "  <whatever/>\n"))
    assert parse(path, warnings=None).name == "pkg"


def test_duplicate_dependency_and_leading_zero_version_warn(tmp_path: Path) -> None:
    text = manifest(3, "  <exec_depend>rclpy</exec_depend>\n  <exec_depend>rclpy</exec_depend>\n")
    text = text.replace("<version>1.2.3</version>", "<version>1.02.3</version>")
    path = write(tmp_path, text)
    warnings: list[str] = []
    package = parse(path, warnings=warnings)
    assert [d.name for d in package.dependencies] == ["rclpy"]
    assert any("duplicate <exec_depend> on 'rclpy'" in w for w in warnings)
    assert any("leading zeros" in w for w in warnings)


# --- version constraints ---------------------------------------------------------------------


def test_version_constraints_are_kept(tmp_path: Path) -> None:
    body = """\
  <depend version_gte="1.0.0" version_lt="2.0.0">rclcpp</depend>
  <exec_depend version_eq="3.1.4">exact</exec_depend>
  <build_depend version_lte="5.0.0">at_most</build_depend>
  <test_depend version_gt="0.1.0">newer</test_depend>
"""
    package = parse(write(tmp_path, manifest(3, body)))
    by_name = {d.name: d.constraints for d in package.dependencies}
    assert by_name["rclcpp"] == (
        VersionConstraint("lt", "2.0.0"),
        VersionConstraint("gte", "1.0.0"),
    )
    assert by_name["exact"] == (VersionConstraint("eq", "3.1.4"),)
    assert by_name["at_most"] == (VersionConstraint("lte", "5.0.0"),)
    assert by_name["newer"] == (VersionConstraint("gt", "0.1.0"),)


def _workspace(tmp_path: Path, deps: str, lib_version: str) -> dict[str, Package]:
    app = write(tmp_path, manifest(3, deps, name="app"), folder="app")
    lib = write(tmp_path, manifest(3, name="lib").replace("1.2.3", lib_version), folder="lib")
    packages = [parse(app), parse(lib)]
    return {p.name: p for p in packages}


def test_violated_constraints_are_reported(tmp_path: Path) -> None:
    deps = """\
  <depend version_gte="2.0.0">lib</depend>
  <exec_depend version_gte="0.1.0">not_in_workspace</exec_depend>
"""
    packages = _workspace(tmp_path, deps, "1.4.0")
    messages = check_version_constraints(packages)
    manifest_path = packages["app"].manifest
    assert manifest_path is not None
    line = line_of(manifest_path, "<depend")
    # One message although <depend> expands to three dependency records.
    assert messages == [
        f"{manifest_path}:{line}: 'app' requires 'lib' version_gte=\"2.0.0\" (>= 2.0.0) "
        "but the workspace has 'lib' 1.4.0"
    ]


@pytest.mark.parametrize(
    ("attribute", "violated"),
    [
        ('version_lt="1.4.0"', True), ('version_lt="1.10.0"', False),
        ('version_lte="1.4.0"', False), ('version_lte="1.3.9"', True),
        ('version_eq="1.4.0"', False), ('version_eq="1.4.1"', True),
        ('version_gte="1.4.0"', False), ('version_gte="1.10.0"', True),
        ('version_gt="1.4.0"', True), ('version_gt="1.3.99"', False),
        ('version_gte="1.0.0" version_lt="2.0.0"', False),
        ('version_gte="1.0.0" version_lt="1.2.0"', True),
    ],
)
def test_each_constraint_operator(tmp_path: Path, attribute: str, violated: bool) -> None:
    packages = _workspace(tmp_path, f"  <exec_depend {attribute}>lib</exec_depend>\n", "1.4.0")
    messages = check_version_constraints(packages)
    assert bool(messages) is violated
    # Versions compare numerically, not as strings ("1.10.0" > "1.4.0").
    for message in messages:
        assert "'lib' 1.4.0" in message


def test_unparseable_constraint_is_reported(tmp_path: Path) -> None:
    packages = _workspace(tmp_path, '  <exec_depend version_gte="one">lib</exec_depend>\n', "1.0.0")
    [message] = check_version_constraints(packages)
    assert "not a valid version" in message


def test_constraint_versions_cannot_hold_spaces_or_quotes(tmp_path: Path) -> None:
    body = '  <exec_depend version_gte="1.0 &quot;x">lib</exec_depend>\n'
    path = write(tmp_path, manifest(3, body))
    with pytest.raises(ManifestError) as info:
        parse(path)
    assert "invalid version_gte '1.0 \"x' on <exec_depend> 'lib'" in str(info.value)


def test_bloom_style_constraint_versions_are_kept(tmp_path: Path) -> None:
    body = '  <exec_depend version_eq="1.9.3-r0">lib</exec_depend>\n'
    package = parse(write(tmp_path, manifest(3, body)))
    assert package.dependencies[0].constraints == (VersionConstraint("eq", "1.9.3-r0"),)


# --- bad manifests ----------------------------------------------------------------------------

#: file in tests/data/bad_manifests → (line, fragment of the message)
BAD = {
    "not_xml.xml": (4, "not well-formed XML: Opening and ending tag mismatch"),
    "empty_file.xml": (1, "not well-formed XML: Document is empty"),
    "wrong_root.xml": (2, "the root element is <manifest>, not <package>"),
    "unknown_format.xml": (2, "unknown package format '4'"),
    "missing_name.xml": (2, "missing <name>"),
    "missing_version.xml": (2, "missing <version>"),
    "missing_description.xml": (2, "missing <description>"),
    "missing_maintainer.xml": (2, "missing <maintainer>"),
    "missing_license.xml": (2, "missing <license>"),
    "maintainer_without_email.xml": (6, "<maintainer> 'Dev' has no email"),
    "name_uppercase_dash.xml": (3, "invalid package name 'My-Pkg'"),
    "name_path.xml": (3, "invalid package name '../x'"),
    "name_shell.xml": (3, "invalid package name '$(touch x)'"),
    "name_empty.xml": (3, "the package name is empty"),
    "two_names.xml": (8, "more than one <name> (the first is on line 3)"),
    "markup_in_name.xml": (3, "<name> must contain only text"),
    "invalid_version.xml": (4, "invalid version '1.0'"),
    "invalid_version_suffix.xml": (4, "invalid version '1.0.0-beta'"),
    "depend_in_format1.xml": (8, "<depend> is not allowed in package format 1"),
    "run_depend_in_format3.xml": (8, "<run_depend> is not allowed in package format 3"),
    "group_depend_in_format2.xml": (8, "<group_depend> is not allowed in package format 2"),
    "condition_in_format2.xml": (8, "condition attribute on <depend> 'rclcpp' needs package format"),
    "bad_condition.xml": (8, "<depend> has an invalid condition: condition '$ROS_VERSION = 2'"),
    "unbalanced_condition.xml": (8, "is not closed"),
    "bad_build_type_condition.xml": (9, "<build_type> has an invalid condition"),
    "unknown_build_type.xml": (9, "unknown build type 'catkin'"),
    "two_build_types.xml": (10, "several <build_type> elements apply"),
    "no_build_type_applies.xml": (9, "no <build_type> condition holds in this environment"),
    "no_build_type_no_files.xml": (2, "neither CMakeLists.txt nor setup.py"),
    "dependency_shell.xml": (8, "invalid dependency name '$(x)' in <depend>"),
    "dependency_path.xml": (8, "invalid dependency name '../other'"),
    "dependency_space.xml": (8, "invalid dependency name 'two words'"),
    "dependency_empty.xml": (8, "empty <exec_depend>"),
    "empty_constraint.xml": (8, "empty version_gte on <depend> 'rclcpp'"),
    "redundant_depend.xml": (9, "<depend> on 'rclcpp' is redundant with <exec_depend>"),
    "self_dependency.xml": (8, "the package 'narcissus' depends on itself"),
    "bad_group_name.xml": (8, "invalid group name 'Interface-Packages'"),
    "group_depend_and_member.xml": (8, "depends on group 'my_group' and is a member of it"),
}


def test_the_corpus_is_complete() -> None:
    assert sorted(p.name for p in BAD_MANIFESTS.glob("*.xml")) == sorted(BAD)


@pytest.mark.parametrize("filename", sorted(BAD))
def test_bad_manifest_is_one_line_error_with_file_line_and_hint(filename: str) -> None:
    line, fragment = BAD[filename]
    path = BAD_MANIFESTS / filename
    warnings: list[str] = []
    with pytest.raises(ManifestError) as info:
        parse_manifest(path, environ={}, known_build_types=KNOWN, warnings=warnings)
    error = info.value
    text = str(error)
    assert "\n" not in text and "\r" not in text
    assert text.startswith(f"{path}:{line}: "), text
    assert fragment in text
    assert error.path == path and error.line == line
    assert error.hint and f"({error.hint})" in text


def test_invalid_name_hint_states_the_rule_and_a_fix() -> None:
    with pytest.raises(ManifestError) as info:
        parse(BAD_MANIFESTS / "name_uppercase_dash.xml")
    assert info.value.hint == f"{PACKAGE_NAME_RULE}, e.g. 'my_pkg'"


def test_malformed_condition_is_a_condition_error() -> None:
    with pytest.raises(ConditionError) as info:
        parse(BAD_MANIFESTS / "bad_condition.xml")
    assert info.value.hint == "use '==' to compare"


def test_control_characters_in_names_stay_on_one_line(tmp_path: Path) -> None:
    path = write(tmp_path, manifest(3, name="evil&#10;name&#13;x"))
    with pytest.raises(ManifestError) as info:
        parse(path)
    assert "\n" not in str(info.value) and "\r" not in str(info.value)
    assert "'evil\\nname\\rx'" in str(info.value)


def test_multi_line_maintainer_name_stays_on_one_line(tmp_path: Path) -> None:
    text = manifest(3).replace(
        '<maintainer email="dev@example.com">Dev Eloper</maintainer>',
        "<maintainer>Dev\n    Eloper</maintainer>",
    )
    with pytest.raises(ManifestError) as info:
        parse(write(tmp_path, text))
    assert "\n" not in str(info.value)
    assert "<maintainer> 'Dev Eloper' has no email" in str(info.value)


def test_unreadable_manifest_is_a_manifest_error(tmp_path: Path) -> None:
    path = tmp_path / "gone" / "package.xml"
    with pytest.raises(ManifestError) as info:
        parse(path)
    assert str(info.value).startswith(f"{path}: cannot read the package manifest")


def test_redundant_test_depend_in_format_1(tmp_path: Path) -> None:
    body = "  <run_depend>rospy</run_depend>\n  <test_depend>rospy</test_depend>\n"
    path = write(tmp_path, manifest(1, body))
    with pytest.raises(ManifestError, match="<test_depend> on 'rospy' is redundant with <run_dep"):
        parse(path)


def test_depend_with_different_conditions_is_not_redundant(tmp_path: Path) -> None:
    body = """\
  <depend condition="$ROS_VERSION == 2">rclcpp</depend>
  <exec_depend condition="$ROS_VERSION == 1">rclcpp</exec_depend>
"""
    package = parse(write(tmp_path, manifest(3, body)))
    assert {d.kind for d in package.dependencies} == {
        DepKind.BUILD, DepKind.BUILD_EXPORT, DepKind.EXEC}


@pytest.mark.parametrize("ros_version", ["1", "2"])
def test_a_malformed_condition_is_an_error_in_every_environment(
    tmp_path: Path, ros_version: str
) -> None:
    body = """\
  <depend condition="$ROS_VERSION == 1">a</depend>
  <depend condition="$ROS_VERSION 1">b</depend>
"""
    path = write(tmp_path, manifest(3, body))
    with pytest.raises(ConditionError) as info:
        parse(path, {"ROS_VERSION": ros_version})
    assert info.value.line == line_of(path, ">b<")


# --- names --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["a", "rclcpp", "my_pkg2", "x_1_y"])
def test_valid_package_names(name: str) -> None:
    assert is_valid_package_name(name)


@pytest.mark.parametrize(
    "name",
    [
        "", "My-Pkg", "my-pkg", "Pkg", "1pkg", "_pkg", "../x", "$(touch x)", "a b", "pkg\n",
        "päckage",
    ],
)
def test_invalid_package_names(name: str) -> None:
    assert not is_valid_package_name(name)
    assert "lowercase" in PACKAGE_NAME_RULE


@pytest.mark.parametrize(
    ("name", "valid"),
    [
        ("python3-numpy", True), ("libstdc++6", True), ("libgstreamer0.10-dev", True),
        ("Eigen3", True), ("$(x)", False), ("a b", False), ("a/b", False), ("-rf", False),
        ("..", False), ("", False), ("x;y", False), ("`x`", False),
    ],
)
def test_dependency_name_rule(name: str, valid: bool) -> None:
    assert is_valid_dependency_name(name) is valid
    assert DEPENDENCY_NAME_RULE


# --- speed ------------------------------------------------------------------------------------


def test_parsing_many_manifests_keeps_them_apart(tmp_path: Path) -> None:
    # Parsing speed is measured in benchmarks/ (`list` on 1,000 packages), not asserted here.
    body = """\
  <buildtool_depend>ament_cmake</buildtool_depend>
  <depend>rclcpp</depend>
  <depend condition="$ROS_VERSION == 2">std_msgs</depend>
  <test_depend>ament_lint_auto</test_depend>
"""
    paths = [
        write(tmp_path, manifest(3, body, name=f"pkg_{i}"), folder=f"pkg_{i}") for i in range(500)
    ]
    packages = [parse(path) for path in paths]
    assert [p.name for p in packages] == [f"pkg_{i}" for i in range(500)]
    assert all(p.dependency_names(DepCategory.BUILD) >= {"rclcpp", "std_msgs"} for p in packages)


def test_dependency_records_are_model_objects(tmp_path: Path) -> None:
    package = parse(write(tmp_path, manifest(3, "  <exec_depend>rclpy</exec_depend>\n")))
    line = line_of(package.manifest or Path(), "rclpy")
    assert package.dependencies == (Dependency("rclpy", DepKind.EXEC, (), line),)
