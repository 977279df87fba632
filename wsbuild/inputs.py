"""Inputs a run's answer depends on that it does not read itself: the directories a program
it starts searches (pkg-config's search path), for whoever keeps the run's record.

The no-op replay (engine/replay.py) answers a command again only while every input of its
last run is unchanged. The run's own reads are seen where they happen (engine/recording.py);
what a subprocess reads is not, so the code that starts it declares it here. Declaring costs
nothing when nobody listens (a run that is not recorded)."""

from __future__ import annotations

from collections.abc import Callable

#: called with (absolute path, is a directory whose entries count)
Listener = Callable[[str, bool], None]
_listeners: list[Listener] = []


def declare_file(path: str) -> None:
    """The run's answer depends on the file at `path` (or on its absence)."""
    for listener in _listeners:
        listener(path, False)


def declare_directory(path: str) -> None:
    """The run's answer depends on which entries the directory at `path` holds (and on each
    entry's signature): a program searched it."""
    for listener in _listeners:
        listener(path, True)


def listen(listener: Listener) -> Callable[[], None]:
    """Hear every declaration until the returned function is called."""
    _listeners.append(listener)
    return lambda: _listeners.remove(listener) if listener in _listeners else None
