"""Whether CMake configures again is asked of record/ (record/configured.py) and answered with
the typed reason a package's build is explained with; `--dry-run` prints it beside the
configure step, and its JSON gives the kind."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from test_build_helpers import build, clean_env, output, wsbuild, write_cmake
from wsbuild.record.configured import (CONFIGURED_FILE, Configured, decode_configured,
                                       reconfigure_reason)
from wsbuild.record.dirty import Dirty

LAST = Configured("/w/src/p", ("-DA=1", "-GNinja"), {"CC": "d1", "CXX": None})


@pytest.mark.parametrize(("last", "now", "options", "kind", "details"), [
    (LAST, LAST, {"configured": False}, Dirty.NEW, ()),
    (None, LAST, {"configured": True}, Dirty.UNFINISHED, ()),
    (LAST, LAST, {"configured": True, "asked": "--cmake-force-configure"}, Dirty.FORCED,
     ("--cmake-force-configure",)),
    (LAST, LAST, {"configured": True, "redo": ("install", "build")}, Dirty.REREAD, ("build",)),
    (LAST, Configured("/w/src/q", LAST.args, LAST.compilers), {"configured": True},
     Dirty.SOURCE, ("/w/src/p",)),
    (LAST, Configured(LAST.source, ("-DA=2", "-GNinja"), LAST.compilers), {"configured": True},
     Dirty.OPTIONS, ("+-DA=2", "--DA=1")),
    (LAST, Configured(LAST.source, ("-GNinja", "-DA=1"), LAST.compilers), {"configured": True},
     Dirty.OPTIONS, ("their order",)),
    (LAST, Configured(LAST.source, LAST.args, {"CC": "d1", "CXX": "d2"}), {"configured": True},
     Dirty.ENVIRONMENT, ("CXX",)),
])
def test_each_reason_to_configure_again(last: Configured | None, now: Configured,
                                        options: dict[str, object], kind: Dirty,
                                        details: tuple[str, ...]) -> None:
    reason = reconfigure_reason(last, now, **options)  # type: ignore[arg-type]
    assert reason is not None and reason.kind is kind and reason.details == details


def test_a_configure_that_holds_has_no_reason() -> None:
    assert reconfigure_reason(LAST, Configured(LAST.source, LAST.args, dict(LAST.compilers)),
                              configured=True, redo=("install",)) is None


def test_a_kept_configure_that_is_not_one_is_not_trusted() -> None:
    assert decode_configured(LAST.encode()) == LAST
    for broken in ([], {"source": 1, "args": []}, {"source": "/s", "args": [1]},
                   {"source": "/s", "args": [], "environment": {"CC": 3}}):
        assert decode_configured(broken) is None


def _steps(ws: Path, *args: str, env: dict[str, str] | None = None) -> dict[str, dict]:
    """The plan's steps of the package `p` by label (`--dry-run --json`)."""
    result = wsbuild("build", "--dry-run", "--json", *args, cwd=ws, env=env)
    assert result.returncode == 0, output(result)
    package = next(p for p in json.loads(result.stdout)["packages"] if p["name"] == "p")
    return {step["label"]: step for step in package.get("steps", [])}


def test_dry_run_says_why_cmake_configures_again(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "p", "cmake_minimum_required(VERSION 3.14)\nproject(p NONE)\n"
                "install(FILES data.txt DESTINATION share/p)\n", files={"data.txt": "one\n"})
    build(ws)
    # rebuilt (forced), with nothing a configure used changed: no configure
    assert "configure" not in _steps(ws, "--force")
    # another argument: the configure runs, and says why in the words of a package's reason
    steps = _steps(ws, "--cmake-args", "-DWSB_MARK=1")
    why = steps["configure"]["why"]
    assert why["kind"] == "options" and why["details"] == ["+-DWSB_MARK=1"], why
    lines = wsbuild("build", "--dry-run", "--commands", "--cmake-args", "-DWSB_MARK=1",
                    cwd=ws).stdout
    assert "# configure: its arguments changed: +-DWSB_MARK=1" in lines, lines
    # another compiler: from scratch, and why
    why = _steps(ws, "--force", env=clean_env(CC="/no/such/cc"))["configure"]["why"]
    assert why["kind"] == "environment" and why["details"] == ["CC"], why
    # a configure wsbuild did not see finish: again
    (ws / "build" / "p" / CONFIGURED_FILE).unlink()
    assert _steps(ws, "--force")["configure"]["why"]["kind"] == "unfinished"
    # and the build does what the dry run said: configures, and keeps what it used
    build(ws, "--force")
    log = (ws / "log" / "latest_build" / "p" / "stdout_stderr.log").read_text()
    assert "Configuring done" in log
    assert "configure" not in _steps(ws, "--force")
