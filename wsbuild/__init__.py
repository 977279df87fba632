"""wsbuild: a fast, strict ROS 2 workspace builder, install-compatible with colcon."""

__version__ = "0.1.0"
