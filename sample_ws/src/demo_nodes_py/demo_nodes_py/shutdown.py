"""Ctrl-C the way `ros2 launch` expects it: the node exits with code 0 and prints no traceback."""

from __future__ import annotations

import signal
from types import FrameType


def _interrupt(signum: int, frame: FrameType | None) -> None:
    # Ctrl-C reaches both the node and `ros2 launch`, which then sends a SIGINT of its own: the
    # second one must not cut the shutdown short (launch would report "exit code -2")
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    raise KeyboardInterrupt


def interrupt_once() -> None:
    """Make the first SIGINT raise KeyboardInterrupt and ignore any later one.

    Call it before rclpy.init(): rclpy's own handler then shuts the context down and passes
    the signal on to this one.
    """
    signal.signal(signal.SIGINT, _interrupt)
