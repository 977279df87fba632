"""One exit-code map, in cli.py: whatever a verb raises becomes one line and one of 0, 1 (a
package or the machine failed), 2 (usage or workspace), 3 (a bug, with its traceback), 130
(Ctrl-C)."""

from __future__ import annotations

import errno
from collections.abc import Callable
from pathlib import Path

import pytest

from wsbuild import cli
from wsbuild.errors import BuildFailed, Interrupted, ManifestError, WorkspaceError


def _raising(exc: BaseException) -> Callable[[object], int]:
    def verb(_request: object) -> int:
        raise exc
    return verb


@pytest.mark.parametrize(("raised", "code", "first_line"), [
    (ManifestError("bad <depend>", path=Path("src/a/package.xml"), line=7), 2,
     "wsbuild: error: src/a/package.xml:7: bad <depend>"),
    (WorkspaceError("no src/ directory"), 2, "wsbuild: error: no src/ directory"),
    (BuildFailed("1 package failed: a"), 1, "wsbuild: error: 1 package failed: a"),
    (Interrupted("build interrupted"), 130, "wsbuild: error: build interrupted"),
    (KeyboardInterrupt(), 130, "wsbuild: interrupted"),
    (OSError(errno.ENOSPC, "No space left on device", "install/a"), 1,
     "wsbuild: error: no space left on device while running wsbuild list (install/a)"),
    (RuntimeError("unexpected"), 3, "Traceback (most recent call last):"),
])
def test_what_a_verb_raises_is_one_line_and_its_exit_code(
        raised: BaseException, code: int, first_line: str, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(cli, "_resolve_func", lambda _func: _raising(raised))
    assert cli.main(["list"]) == code
    err = capsys.readouterr().err
    assert err.startswith(first_line), err
    if code == 3:
        assert err.rstrip().endswith("this is a bug in wsbuild; please report it with the "
                                     "traceback above")
    else:
        assert len(err.strip().splitlines()) == 1, err
