"""benchmarks/measure.py: trees between timed runs are moved aside, deleted after the last."""

from __future__ import annotations

import sys
from pathlib import Path

from conftest import REPO

sys.path.insert(0, str(REPO))

from benchmarks.measure import DISCARDED, clean_outputs, discard, empty_discarded  # noqa: E402


def test_clean_outputs_moves_aside_until_emptied(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    for name in ("src/pkg", "build/pkg", "install/pkg", "log/latest"):
        (ws / name).mkdir(parents=True)
    (ws / "install" / "pkg" / "file").write_text("x")
    clean_outputs(ws)
    clean_outputs(ws)  # nothing left to move: no error
    assert sorted(p.name for p in ws.iterdir()) == ["src"]
    moved = sorted(p.name.split(".")[0] for p in (tmp_path / DISCARDED).iterdir())
    assert moved == ["ws-build", "ws-install", "ws-log"]

    # the same workspace discarded twice (a fresh clone each round) keeps both
    discard(ws, tmp_path)
    (ws / "src").mkdir(parents=True)
    discard(ws, tmp_path)
    assert len(list((tmp_path / DISCARDED).iterdir())) == 5 and not ws.exists()

    empty_discarded(tmp_path)
    assert not (tmp_path / DISCARDED).exists()
