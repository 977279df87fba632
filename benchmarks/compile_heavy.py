"""The compile-heavy benchmark workspace: rosidl interface packages in a dependency chain, C++ libraries and their users.

Real ROS 2 workspaces spend their full build compiling: the interface packages' generated C,
C++ and Python type support.  This workspace reproduces that shape (see `PLAN`):

    heavy_base_msgs ──┬── heavy_geometry_msgs ──┬── heavy_nav_msgs ─────┬── heavy_mission_msgs
                      │                         └── heavy_control_msgs ─┘        (deepest)
                      └── heavy_sensor_msgs ────────┘ (nav)
    heavy_math (C++ library, no ROS dependency)
    heavy_geometry_lib (library: heavy_math + heavy_geometry_msgs)
    heavy_sensor_monitor (executable: heavy_math + heavy_sensor_msgs)
    heavy_planner (library + executable: heavy_geometry_lib, heavy_nav_msgs, heavy_mission_msgs)

Six interface packages, a chain of depth 3 above the base package with fan-out at every
level, and four `ament_cmake` C++ packages.  Every interface package gets
`interfaces` messages/services/actions (default 10); the contents are generated
deterministically (no randomness), so both tools build byte-identical sources.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from benchmarks.generate import GeneratedPackage, GeneratedWorkspace

#: ROS packages of the underlay the interface packages use
UNDERLAY_MSGS = ("builtin_interfaces", "std_msgs")


@dataclass(frozen=True, slots=True)
class InterfacePlan:
    name: str
    #: interface packages of the workspace this one uses (types in its fields)
    depends: tuple[str, ...]
    #: share of services and actions among its interfaces (the rest are messages)
    services: int
    actions: int


@dataclass(frozen=True, slots=True)
class LibraryPlan:
    name: str
    depends: tuple[str, ...]
    #: number of .cpp files of the library (0: executable only)
    sources: int
    #: whether it also builds an executable using the library
    executable: bool
    #: interface packages whose headers the sources include
    uses_msgs: tuple[str, ...]


INTERFACES = (
    InterfacePlan("heavy_base_msgs", (), services=1, actions=0),
    InterfacePlan("heavy_geometry_msgs", ("heavy_base_msgs",), services=1, actions=0),
    InterfacePlan("heavy_sensor_msgs", ("heavy_base_msgs",), services=1, actions=0),
    InterfacePlan("heavy_control_msgs", ("heavy_geometry_msgs",), services=1, actions=0),
    InterfacePlan("heavy_nav_msgs", ("heavy_geometry_msgs", "heavy_sensor_msgs"), services=1,
                  actions=0),
    InterfacePlan("heavy_mission_msgs", ("heavy_nav_msgs", "heavy_control_msgs"), services=2,
                  actions=1),
)
LIBRARIES = (
    LibraryPlan("heavy_math", (), sources=4, executable=False, uses_msgs=()),
    LibraryPlan("heavy_geometry_lib", ("heavy_math", "heavy_geometry_msgs"), sources=3,
                executable=False, uses_msgs=("heavy_geometry_msgs",)),
    LibraryPlan("heavy_sensor_monitor", ("heavy_math", "heavy_sensor_msgs"), sources=2,
                executable=True, uses_msgs=("heavy_sensor_msgs",)),
    LibraryPlan("heavy_planner",
                ("heavy_geometry_lib", "heavy_nav_msgs", "heavy_mission_msgs"), sources=3,
                executable=True, uses_msgs=("heavy_nav_msgs", "heavy_mission_msgs")),
)
#: the interface package at the end of the longest chain: the edit scenario changes one of its messages
DEEPEST = "heavy_mission_msgs"

_WORDS = (
    "Pose", "Twist", "Wrench", "Accel", "Inertia", "Polygon", "Vector", "Point", "Frame",
    "Track", "Range", "Scan", "Cloud", "Image", "Joint", "Battery", "Status", "Command",
    "Target", "Waypoint", "Route", "Grid", "Limit", "Gain", "Mode", "Event", "Sample",
    "Reading", "Marker", "Zone",
)
#: (ROS type, C++ expression that reads it as a number) for the primitive fields
_PRIMITIVES = (
    ("float64", "{}"), ("float32", "{}"), ("int32", "{}"), ("uint32", "{}"), ("int64", "{}"),
    ("uint8", "{}"), ("int16", "{}"), ("bool", "({} ? 1.0 : 0.0)"), ("uint64", "{}"),
    ("int8", "{}"),
)


@dataclass(frozen=True, slots=True)
class CompileHeavySpec:
    """How big the generated workspace is: interfaces per interface package."""

    interfaces: int = 10

    def __post_init__(self) -> None:
        if not 6 <= self.interfaces <= len(_WORDS):
            raise ValueError(f"interfaces per package must be 6..{len(_WORDS)}")


@dataclass(frozen=True, slots=True)
class Interface:
    kind: str  # "msg", "srv" or "action"
    name: str
    text: str


def _snake(name: str) -> str:
    out = []
    for i, char in enumerate(name):
        if char.isupper() and i:
            out.append("_")
        out.append(char.lower())
    return "".join(out)


def message_names(spec: CompileHeavySpec, plan: InterfacePlan) -> list[str]:
    return [word for word in _WORDS[:spec.interfaces - plan.services - plan.actions]]


def _fields(package: str, index: int, own: list[str], used: list[tuple[str, str]],
            count: int) -> list[str]:
    """`count` fields: primitives, arrays, strings, and references to other messages."""
    lines = []
    offset = (sum(map(ord, package)) + index) % len(_PRIMITIVES)
    for i in range(count):
        ros_type, _ = _PRIMITIVES[(offset + i) % len(_PRIMITIVES)]
        lines.append(f"{ros_type} value_{i}")
    lines.append("float64[] samples")
    lines.append("float32[9] covariance")
    lines.append("string<=64 label")
    lines.append("string[] tags")
    if own:
        lines.append(f"{own[index % len(own)]} nested")
        lines.append(f"{own[(index * 7) % len(own)]}[<=4] history")
    for dep_package, dep_type in used:
        lines.append(f"{dep_package}/{dep_type} {_snake(dep_type)}_from_{dep_package.split('_')[1]}")
    return lines


def plan_interfaces(spec: CompileHeavySpec, plan: InterfacePlan) -> list[Interface]:
    """The .msg/.srv/.action files of one interface package (deterministic)."""
    messages = message_names(spec, plan)
    dep_messages = {dep: message_names(spec, next(p for p in INTERFACES if p.name == dep))
                    for dep in plan.depends}
    result: list[Interface] = []
    for index, name in enumerate(messages):
        header = ["# Synthetic benchmark message", f"uint8 KIND_{name.upper()} = {index + 1}",
                  "std_msgs/Header header", "builtin_interfaces/Duration age"]
        used = [(dep, names[(index + k) % len(names)])
                for k, (dep, names) in enumerate(sorted(dep_messages.items()))]
        body = _fields(plan.name, index, messages[:index], used, count=2 + index % 3)
        result.append(Interface("msg", name, "\n".join(header + body) + "\n"))
    for index in range(plan.services):
        word = messages[index % len(messages)]
        request = [f"{word} request_item", "uint32 id", "string name"]
        response = ["bool success", "string message", f"{messages[-1 - index]}[] items"]
        text = "\n".join(["# Synthetic benchmark service", *request, "---", *response])
        result.append(Interface("srv", f"Set{word}", text + "\n"))
    for index in range(plan.actions):
        word = messages[(index + 3) % len(messages)]
        goal = [f"{word} target", "float64 tolerance"]
        done = ["bool reached", f"{messages[index % len(messages)]} final_state"]
        feedback = ["float32 progress", f"{word} current"]
        text = "\n".join(["# Synthetic benchmark action", *goal, "---", *done, "---", *feedback])
        result.append(Interface("action", f"Run{word}", text + "\n"))
    return result


INTERFACE_XML = """<?xml version="1.0"?>
<?xml-model href="http://download.ros.org/schema/package_format3.xsd" schematypens="http://www.w3.org/2001/XMLSchema"?>
<package format="3">
  <name>{name}</name>
  <version>0.0.0</version>
  <description>Synthetic compile-heavy benchmark interfaces {name}</description>
  <maintainer email="bench@example.com">bench</maintainer>
  <license>Apache-2.0</license>

  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>

{depends}
  <exec_depend>rosidl_default_runtime</exec_depend>

  <member_of_group>rosidl_interface_packages</member_of_group>

  <export>
    <build_type>ament_cmake</build_type>
  </export>
</package>
"""

INTERFACE_CMAKE = """cmake_minimum_required(VERSION 3.14)
project({name})

find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
{find_packages}
rosidl_generate_interfaces(${{PROJECT_NAME}}
{files}
  DEPENDENCIES {dependencies}
)

ament_export_dependencies(rosidl_default_runtime)
ament_package()
"""

LIBRARY_XML = """<?xml version="1.0"?>
<?xml-model href="http://download.ros.org/schema/package_format3.xsd" schematypens="http://www.w3.org/2001/XMLSchema"?>
<package format="3">
  <name>{name}</name>
  <version>0.0.0</version>
  <description>Synthetic compile-heavy benchmark C++ package {name}</description>
  <maintainer email="bench@example.com">bench</maintainer>
  <license>Apache-2.0</license>

  <buildtool_depend>ament_cmake</buildtool_depend>

{depends}
  <export>
    <build_type>ament_cmake</build_type>
  </export>
</package>
"""

LIBRARY_CMAKE = """cmake_minimum_required(VERSION 3.14)
project({name} LANGUAGES CXX)

if(NOT CMAKE_CXX_STANDARD)
  set(CMAKE_CXX_STANDARD 17)
endif()

find_package(ament_cmake REQUIRED)
{find_packages}
{targets}
ament_package()
"""

LIBRARY_TARGET = """add_library(${{PROJECT_NAME}}
{sources})
target_include_directories(${{PROJECT_NAME}} PUBLIC
  "$<BUILD_INTERFACE:${{CMAKE_CURRENT_SOURCE_DIR}}/include>"
  "$<INSTALL_INTERFACE:include/${{PROJECT_NAME}}>")
target_link_libraries(${{PROJECT_NAME}} PUBLIC {links})
install(DIRECTORY include/ DESTINATION include/${{PROJECT_NAME}})
install(TARGETS ${{PROJECT_NAME}} EXPORT export_${{PROJECT_NAME}}
  ARCHIVE DESTINATION lib LIBRARY DESTINATION lib RUNTIME DESTINATION bin)
ament_export_targets(export_${{PROJECT_NAME}} HAS_LIBRARY_TARGET)
ament_export_dependencies({exports})
"""

EXECUTABLE_TARGET = """add_executable({name}_node src/main.cpp)
target_link_libraries({name}_node PRIVATE {links})
install(TARGETS {name}_node DESTINATION lib/${{PROJECT_NAME}})
"""

HEADER = """#pragma once

#include <cstddef>
#include <vector>

namespace {name} {{

// Synthetic benchmark API: a few numeric kernels over the workspace's messages.
{declarations}
}}  // namespace {name}
"""

MATH_SOURCE = """#include "{name}/{name}.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <string>

namespace {name} {{

namespace {{
template <typename T, std::size_t N>
struct Kernel{index} {{
  static T apply(const std::vector<T> & values) {{
    std::map<std::string, T> seen;
    T total{{}};
    for (std::size_t i = 0; i < values.size(); ++i) {{
      total += static_cast<T>(std::pow(values[i], 1 + (i + N) % 3));
      seen[std::to_string(i % (N + 1))] += values[i];
    }}
    return total + std::accumulate(values.begin(), values.end(), T{{}}) + static_cast<T>(seen.size());
  }}
}};
}}  // namespace

double kernel_{index}(const std::vector<double> & values)
{{
  return Kernel{index}<double, {index}>::apply(values) + Kernel{index}<float, {index} + 1>::apply(
    std::vector<float>(values.begin(), values.end()));
}}

}}  // namespace {name}
"""

MSG_SOURCE = """#include "{name}/{name}.hpp"

#include <numeric>
#include <vector>

{includes}
{extra_includes}
namespace {name} {{

double kernel_{index}(const std::vector<double> & values)
{{
  double total = std::accumulate(values.begin(), values.end(), 0.0);
{body}  return total;
}}

}}  // namespace {name}
"""

MAIN_SOURCE = """#include <cstdio>
#include <vector>

#include "{name}/{name}.hpp"

int main()
{{
  std::vector<double> values{{1.0, 2.0, 3.0}};
  double total = 0.0;
{calls}  std::printf("{name}: %f\\n", total);
  return 0;
}}
"""


def _depends_xml(depends: list[str]) -> str:
    return "".join(f"  <depend>{d}</depend>\n" for d in depends)


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.is_file() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _interface_package(root: Path, spec: CompileHeavySpec, plan: InterfacePlan) -> None:
    interfaces = plan_interfaces(spec, plan)
    uses_actions = any(i.kind == "action" for i in interfaces)
    depends = [*UNDERLAY_MSGS, *(["action_msgs"] if uses_actions else []), *plan.depends]
    _write(root / "package.xml", INTERFACE_XML.format(name=plan.name, depends=_depends_xml(depends)))
    files = "\n".join(f'  "{i.kind}/{i.name}.{i.kind}"' for i in interfaces)
    _write(root / "CMakeLists.txt", INTERFACE_CMAKE.format(
        name=plan.name, files=files, dependencies=" ".join(depends),
        find_packages="".join(f"find_package({d} REQUIRED)\n" for d in depends)))
    for interface in interfaces:
        _write(root / interface.kind / f"{interface.name}.{interface.kind}", interface.text)


def _message_includes(spec: CompileHeavySpec, msgs_package: str) -> list[tuple[str, str]]:
    """(header, C++ type) of a few messages of `msgs_package`."""
    plan = next(p for p in INTERFACES if p.name == msgs_package)
    names = message_names(spec, plan)[:4]
    return [(f"{msgs_package}/msg/{_snake(n)}.hpp", f"{msgs_package}::msg::{n}") for n in names]


def _library_package(root: Path, spec: CompileHeavySpec, plan: LibraryPlan) -> None:
    name = plan.name
    _write(root / "package.xml", LIBRARY_XML.format(name=name, depends=_depends_xml(list(plan.depends))))
    finds = "".join(f"find_package({d} REQUIRED)\n" for d in plan.depends)
    links = " ".join(f"${{{d}_TARGETS}}" if d.endswith("_msgs") else f"{d}::{d}"
                     for d in plan.depends)
    sources = [f"src/part_{i}.cpp" for i in range(plan.sources)]
    targets = LIBRARY_TARGET.format(
        sources="".join(f"  {s}\n" for s in sources), links=links,
        exports=" ".join(plan.depends) or "ament_cmake")
    if plan.executable:
        targets += EXECUTABLE_TARGET.format(name=name, links="${PROJECT_NAME}")
    _write(root / "CMakeLists.txt", LIBRARY_CMAKE.format(name=name, find_packages=finds,
                                                         targets=targets))
    declarations = "".join(f"double kernel_{i}(const std::vector<double> & values);\n"
                           for i in range(plan.sources))
    _write(root / "include" / name / f"{name}.hpp", HEADER.format(name=name,
                                                                   declarations=declarations))
    includes = [inc for msgs in plan.uses_msgs for inc in _message_includes(spec, msgs)]
    uses_math = "heavy_math" in plan.depends
    for i in range(plan.sources):
        if not includes:
            _write(root / "src" / f"part_{i}.cpp", MATH_SOURCE.format(name=name, index=i))
            continue
        chosen = includes[i::max(1, plan.sources)] or includes[:1]
        body = "".join(
            f"  {cpp} m{k};\n  total += static_cast<double>(sizeof(m{k})) + m{k}.samples.size();\n"
            for k, (_, cpp) in enumerate(chosen))
        if uses_math:
            body += "  total += heavy_math::kernel_0(values);\n"
        extra = '#include "heavy_math/heavy_math.hpp"\n' if uses_math else ""
        _write(root / "src" / f"part_{i}.cpp", MSG_SOURCE.format(
            name=name, index=i, includes="".join(f'#include "{h}"\n' for h, _ in chosen),
            extra_includes=extra, body=body))
    if plan.executable:
        calls = "".join(f"  total += {name}::kernel_{i}(values);\n" for i in range(plan.sources))
        _write(root / "src" / "main.cpp", MAIN_SOURCE.format(name=name, calls=calls))


def plan_workspace(spec: CompileHeavySpec) -> list[GeneratedPackage]:
    """Every package with its workspace dependencies, without touching the disk."""
    packages = [GeneratedPackage(p.name, "ament_cmake", Path("src") / "interfaces" / p.name,
                                 tuple(sorted(p.depends))) for p in INTERFACES]
    packages += [GeneratedPackage(p.name, "ament_cmake", Path("src") / "libraries" / p.name,
                                  tuple(sorted(p.depends))) for p in LIBRARIES]
    return packages


def generate_compile_heavy(root: Path, spec: CompileHeavySpec = CompileHeavySpec()) -> GeneratedWorkspace:
    """Write the workspace's `src/` under `root` (idempotent: unchanged files keep their mtime)."""
    root = root.resolve()
    planned = plan_workspace(spec)
    for plan in INTERFACES:
        _interface_package(root / "src" / "interfaces" / plan.name, spec, plan)
    for library in LIBRARIES:
        _library_package(root / "src" / "libraries" / library.name, spec, library)
    return GeneratedWorkspace(root=root, packages=tuple(planned))


def edited_message(root: Path, spec: CompileHeavySpec = CompileHeavySpec()) -> Path:
    """The .msg of the deepest interface package the edit scenario changes (one the C++
    packages include, so their users really recompile)."""
    plan = next(p for p in INTERFACES if p.name == DEEPEST)
    name = message_names(spec, plan)[0]
    return root.resolve() / "src" / "interfaces" / DEEPEST / "msg" / f"{name}.msg"


def dependents_of(package: str, workspace: GeneratedWorkspace) -> list[str]:
    """`package` and every package that depends on it, directly or not (sorted)."""
    found = {package}
    changed = True
    while changed:
        changed = False
        for p in workspace.packages:
            if p.name not in found and found & set(p.depends):
                found.add(p.name)
                changed = True
    return sorted(found)
