"""wsbuild: a fast, strict ROS 2 workspace builder, install-compatible with colcon."""

from wsbuild import dataclass_code

__version__ = "0.1.0"

# before any module of wsbuild defines a dataclass: their methods' code, kept between runs
dataclass_code.keep()
