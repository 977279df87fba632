"""Setpoint arithmetic and log formatting shared by the nodes (pure Python, no ROS)."""

from __future__ import annotations

import math


def sine_setpoint(t: float, amplitude: float, period: float) -> float:
    """The setpoint at time `t` seconds of a sine wave of `amplitude` and `period` seconds."""
    if period <= 0.0:
        raise ValueError(f'period must be positive, got {period}')
    return amplitude * math.sin(2.0 * math.pi * t / period)


def clamp(value: float, limit: float) -> float:
    """`value` limited to [-limit, limit]; a joint never receives more than its limit."""
    if limit < 0.0:
        raise ValueError(f'limit must not be negative, got {limit}')
    return max(-limit, min(limit, value))


def describe_setpoint(joint_name: str, value: float) -> str:
    """The line move_joint logs for every setpoint it receives."""
    return f'{joint_name} <- {value:+.3f} rad'
