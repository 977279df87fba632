"""The one stat signature: what says that a path is as it was when a record, a memo or a replay
last looked at it (its type and mode, inode, size, modification and change times). Cheap to
import: the replay (engine/replay.py) uses it before anything else is imported."""

from __future__ import annotations

import os


def stat_signature(st: os.stat_result) -> tuple[int, int, int, int, int]:
    """`st` as the records, memos and replays compare it."""
    return (st.st_mode, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
