"""Nodes of the wsbuild sample workspace (helpers import nothing from ROS, so tests need no DDS)."""
