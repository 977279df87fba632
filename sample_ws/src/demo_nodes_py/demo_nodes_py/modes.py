"""The mode state machine behind the ChangeMode service (pure Python, no ROS)."""

from __future__ import annotations

from dataclasses import dataclass

MODES = ('idle', 'position', 'velocity')


@dataclass(frozen=True)
class ModeChange:
    """The outcome of one request: the service response, field for field."""

    success: bool
    previous_mode: str
    message: str


def change_mode(current: str, requested: str) -> tuple[str, ModeChange]:
    """The new mode and the answer for a request to switch from `current` to `requested`."""
    if requested not in MODES:
        allowed = ', '.join(MODES)
        message = f"unknown mode '{requested}' (allowed: {allowed})"
        return current, ModeChange(False, current, message)
    if requested == current:
        return current, ModeChange(True, current, f'already in {current} mode')
    return requested, ModeChange(True, current, f'switched from {current} to {requested}')
