"""A no-op build is replayed from the record of the last no-op (engine/replay.py) only while
everything that no-op looked at is unchanged: any change to the workspace, its build state,
its install tree, a defaults file, the environment or the underlay sends the build down the
full path, which plans (and builds) as before."""

from __future__ import annotations

import fcntl
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from conftest import run_wsbuild as run_in_environment
from conftest import (
    install_probe_distribution,
    needing_a_missing_distribution,
    write_package,
)

from wsbuild import cli, launch
from wsbuild.engine import replay
from wsbuild.engine.recording import WHY_NOT
from wsbuild.record.environment import environment_digests, environment_reason
from wsbuild.record.reason import Dirty
from wsbuild.terminal import is_per_tab

#: a recording run must start this long after the last change it could read (engine/recording.py's
#: racy rule): a change in the same timestamp tick as the read would not show
SETTLE = 1.1
#: pytest names the test and its phase in the environment: the record's key holds the
#: environment, so the runs here leave it out
PYTEST_VARIABLE = "PYTEST_CURRENT_TEST"
WARNING = "build dependencies not found"


def run_wsbuild(*args: str, cwd: Path,
                env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    environ = dict(os.environ if env is None else env)
    environ.pop(PYTEST_VARIABLE, None)
    return run_in_environment(*args, cwd=cwd, env=environ)


class Runs:
    """`wsbuild build` run in this process (as the `wsbuild` command runs it), telling
    whether the full command line ran or the record answered."""

    def __init__(self, ws: Path, monkeypatch: pytest.MonkeyPatch,
                 capsys: pytest.CaptureFixture[str]) -> None:
        self.capsys = capsys
        self.full: list[bool] = []
        real = cli.main

        def counted(argv: list[str] | None = None, **kwargs: object) -> int:
            self.full.append(True)
            return real(argv, **kwargs)  # type: ignore[arg-type]

        monkeypatch.setattr(cli, "main", counted)
        monkeypatch.chdir(ws)

    def build(self, *args: str) -> tuple[int, str, bool]:
        """(exit code, what it printed, whether it was replayed)"""
        os.environ.pop(PYTEST_VARIABLE, None)
        before = len(self.full)
        saved = sys.argv
        sys.argv = ["wsbuild", "build", *args]
        try:
            code = launch.main()
        finally:
            sys.argv = saved
        out = self.capsys.readouterr()
        return code, out.out + out.err, len(self.full) == before


def _why_not(ws: Path) -> str:
    """What the recorder says of why the last run left no record (engine/recording.py)."""
    why = ws / replay.RECORDINGS / WHY_NOT
    return why.read_text() if why.is_file() else "(it says nothing)"


@pytest.fixture
def built(make_workspace: Callable[..., Path], monkeypatch: pytest.MonkeyPatch) -> Path:
    """An ament_python and a cmake package, built, with no defaults file of the user's."""
    ws = make_workspace({"pa": ("ament_python", []), "pc": ("cmake", [])})
    home = ws.parent / "colcon-home"
    home.mkdir()
    monkeypatch.setenv("COLCON_HOME", str(home))
    monkeypatch.delenv("COLCON_DEFAULTS_FILE", raising=False)
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    first = run_wsbuild("build", cwd=ws)
    assert first.returncode == 0, first.stdout + first.stderr
    time.sleep(SETTLE)
    return ws


@pytest.fixture
def recorded(built: Path, monkeypatch: pytest.MonkeyPatch,
             capsys: pytest.CaptureFixture[str]) -> tuple[Path, Runs]:
    """`built`, after a no-op (the real command) that left a record."""
    no_op = run_wsbuild("build", cwd=built)
    assert no_op.returncode == 0 and "2 packages up to date" in no_op.stdout, no_op.stderr
    assert (built / replay.recording_path("build")).is_file(), \
        f"a no-op of settled inputs leaves a record: {_why_not(built)}"
    return built, Runs(built, monkeypatch, capsys)


def test_the_next_no_op_is_replayed_with_the_same_output_and_log(
        recorded: tuple[Path, Runs]) -> None:
    ws, runs = recorded
    full_log = (ws / "log" / "latest_build").resolve()
    code, out, replayed = runs.build()
    assert code == 0 and replayed, out
    assert out.splitlines()[1:] == ["  2 packages up to date"]
    assert out.startswith("Summary: 0 packages finished [")
    run = (ws / "log" / "latest_build").resolve()
    assert run != full_log, "a replayed run has its own log directory"
    assert sorted(p.name for p in run.iterdir()) == sorted(p.name for p in full_log.iterdir())
    assert (run / "up_to_date.log").read_text() == (full_log / "up_to_date.log").read_text()
    report = json.loads((run / "report.json").read_text())
    earlier = json.loads((full_log / "report.json").read_text())
    assert report["packages"] == earlier["packages"]
    assert {p["outcome"] for p in report["packages"]} == {"up to date"}
    assert report["started"] >= earlier["started"]
    timings = json.loads((run / "timings.json").read_text())
    assert [p["package"] for p in timings["packages"]] == ["pa", "pc"]
    # `wsbuild report` draws the replayed run's page like any other's
    drawn = run_wsbuild("report", cwd=ws)
    assert drawn.returncode == 0, drawn.stderr
    assert "2 up to date" in drawn.stdout and (run / "report.html").is_file()


def _edit_source(ws: Path) -> None:
    module = ws / "src" / "pa" / "pa" / "__init__.py"
    module.write_text(module.read_text() + "\nVALUE = 2\n")


def _add_source_file(ws: Path) -> None:
    (ws / "src" / "pa" / "pa" / "extra.py").write_text("EXTRA = 1\n")


def _add_package(ws: Path) -> None:
    write_package(ws / "src", "pn", "cmake")


def _ignore_package(ws: Path) -> None:
    (ws / "src" / "pc" / "COLCON_IGNORE").touch()


def _remove_installed_file(ws: Path) -> None:
    (ws / "install" / "pa" / "share" / "pa" / "package.xml").unlink()


def _workspace_defaults(ws: Path) -> None:
    (ws / "wsbuild.yaml").write_text("build:\n  cmake-args: [-DWSB_PROBE=1]\n")


def _package_metadata(ws: Path) -> None:
    (ws / "colcon.meta").write_text('{"names": {"pc": {"cmake-args": ["-DWSB_PROBE=1"]}}}')


def _user_defaults(ws: Path) -> None:
    (ws.parent / "colcon-home" / "defaults.yaml").write_text(
        "build:\n  cmake-args: [-DWSB_PROBE=1]\n")


def _unfinished_build(ws: Path) -> None:
    marker = ws / "build" / "pc" / ".wsbuild" / "building"
    marker.parent.mkdir(parents=True, exist_ok=True)
    marker.touch()


def _setup_script_removed(ws: Path) -> None:
    (ws / "install" / "setup.bash").unlink()


CHANGES = {
    "a source file edited": (_edit_source, "pa"),
    "a source file added": (_add_source_file, "pa"),
    "a package added": (_add_package, "pn"),
    "a package ignored": (_ignore_package, None),
    "an installed file removed": (_remove_installed_file, "pa"),
    "a workspace defaults file written": (_workspace_defaults, "pc"),
    "the user's defaults file written": (_user_defaults, "pc"),
    "a package's colcon.meta written": (_package_metadata, "pc"),
    "an interrupted build's marker": (_unfinished_build, "pc"),
    "a setup script removed": (_setup_script_removed, None),
}


@pytest.mark.parametrize("change", sorted(CHANGES))
def test_any_change_runs_the_full_build(recorded: tuple[Path, Runs], change: str) -> None:
    ws, runs = recorded
    make, rebuilt = CHANGES[change]
    make(ws)
    code, out, replayed = runs.build()
    assert code == 0, out
    assert not replayed, f"{change}: replayed\n{out}"
    if rebuilt is not None:
        # built, or restored from the build cache where it holds what is needed
        assert f"Finished <<< {rebuilt}" in out or f"Restored <<< {rebuilt}" in out, out
    if change == "a package ignored":
        assert "1 package up to date" in out and "pc" not in out
    if change == "a setup script removed":
        assert (ws / "install" / "setup.bash").is_file(), "the full run writes it again"


@pytest.mark.parametrize("changed", ["a mixin file", "the file COLCON_DEFAULTS_FILE names"])
def test_a_planning_file_changed_after_a_recorded_no_op_runs_the_full_build(
        built: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        changed: str) -> None:
    """Mixin files and defaults files are read through declared inputs (wsbuild/inputs.py):
    a change after a recorded no-op runs the full build, which builds pc with the new
    arguments."""
    if changed == "a mixin file":
        edited = built.parent / "colcon-home" / "mixin" / "probe.mixin"
        edited.parent.mkdir(parents=True)
        edited.write_text('{"build": {"probe": {"cmake-args": ["-DWSB_MIXIN=1"]}}}\n')
        args: tuple[str, ...] = ("--mixin", "probe")
    else:
        edited = built.parent / "defaults.yaml"
        edited.write_text("build:\n  cmake-args: [-DWSB_DEFAULT=1]\n")
        monkeypatch.setenv("COLCON_DEFAULTS_FILE", str(edited))
        args = ()
    assert run_wsbuild("build", *args, cwd=built).returncode == 0
    time.sleep(SETTLE)
    no_op = run_wsbuild("build", *args, cwd=built)
    assert no_op.returncode == 0 and "2 packages up to date" in no_op.stdout, no_op.stdout
    runs = Runs(built, monkeypatch, capsys)
    edited.write_text(edited.read_text().replace("=1", "=2"))

    code, out, replayed = runs.build(*args)

    assert code == 0, out
    assert not replayed, f"{changed}: replayed\n{out}"
    assert "Finished <<< pc" in out, out
    cache = (built / "build" / "pc" / "CMakeCache.txt").read_text()
    assert ("WSB_MIXIN:UNINITIALIZED=2" if changed == "a mixin file"
            else "WSB_DEFAULT:UNINITIALIZED=2") in cache


def test_a_changed_environment_runs_the_full_build(
        recorded: tuple[Path, Runs], monkeypatch: pytest.MonkeyPatch) -> None:
    ws, runs = recorded
    monkeypatch.setenv("CMAKE_PREFIX_PATH", str(ws / "elsewhere"))
    code, out, replayed = runs.build()
    assert code == 0 and not replayed, out
    # other options, another record: the command line is part of it
    assert not runs.build("--packages-select", "pa")[2]


def test_another_terminal_tab_or_editor_window_is_replayed(
        recorded: tuple[Path, Runs], monkeypatch: pytest.MonkeyPatch) -> None:
    """What a terminal or an editor sets per tab and window (terminal.py) reaches no step and
    nothing wsbuild reads: another tab is the same build, answered from the same recording."""
    ws, runs = recorded
    assert runs.build()[2]
    monkeypatch.setenv("GNOME_TERMINAL_SCREEN", "/org/gnome/Terminal/screen/another")
    monkeypatch.setenv("VSCODE_GIT_IPC_HANDLE", "/run/user/1000/vscode-git-another.sock")
    monkeypatch.setenv("SHLVL", "7")
    code, out, replayed = runs.build()
    assert code == 0 and replayed, out


def test_the_replay_asks_of_the_environment_what_a_record_asks(
        recorded: tuple[Path, Runs], monkeypatch: pytest.MonkeyPatch) -> None:
    """One rule (record/environment.py): each variable by a digest of its value (the recording
    keeps no value), LD_LIBRARY_PATH as a set of directories; a variable set since is named in
    the dirty check's words, and the command runs in full."""
    ws, runs = recorded
    monkeypatch.setenv("LD_LIBRARY_PATH", os.pathsep.join(["/wsb/one", "/wsb/two"]))
    runs.build()
    time.sleep(SETTLE)
    runs.build()  # the no-op in this environment, recorded
    assert runs.build()[2]
    monkeypatch.setenv("LD_LIBRARY_PATH", os.pathsep.join(["/wsb/two", "/wsb/one"]))
    assert runs.build()[2], "the same directories in another order are the same environment"
    kept = json.loads((ws / replay.recording_path("build")).read_text())["key"]["environ"]
    monkeypatch.setenv("WSB_TOKEN", "s3cret-token")
    reason = environment_reason(kept, environment_digests(os.environ, leave_out=is_per_tab))
    assert reason is not None and reason.kind is Dirty.ENVIRONMENT, reason
    assert reason.details == ("WSB_TOKEN",)
    code, out, replayed = runs.build()
    assert code == 0 and not replayed, out
    for recording in (ws / replay.RECORDINGS).iterdir():
        assert "s3cret-token" not in recording.read_text()
        assert "/wsb/one" not in recording.read_text()


def test_another_build_holding_the_lock_is_not_replayed_past(
        recorded: tuple[Path, Runs]) -> None:
    ws, _ = recorded
    os.environ.pop(PYTEST_VARIABLE, None)
    fd = os.open(ws / "build" / ".wsbuild.build.lock", os.O_RDWR)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert replay.replay(["build"], launch._drawing) is None
    finally:
        os.close(fd)
    assert replay.replay(["build"], launch._drawing) == 0


def test_inputs_changed_just_before_a_no_op_leave_no_record(
        make_workspace: Callable[..., Path], monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """A file written in the second before the recording run started may have changed in the
    same timestamp tick as the run read it: no record, the next build runs in full."""
    ws = make_workspace({"pa": ("ament_python", [])})
    assert run_wsbuild("build", cwd=ws).returncode == 0
    runs = Runs(ws, monkeypatch, capsys)
    _edit_source(ws)
    assert runs.build()[0] == 0  # builds pa
    code, out, replayed = runs.build()  # a no-op, right after pa's build wrote its state
    assert code == 0 and not replayed and "1 package up to date" in out
    assert not (ws / replay.recording_path("build")).exists()


def test_an_underlay_change_after_a_recorded_no_op_is_noticed(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """A replay repeats the warnings of the run it repeats; a distribution installed into a
    site directory afterwards is seen (the full path runs again)."""
    ws, site = needing_a_missing_distribution(tmp_path)
    monkeypatch.setenv("PYTHONPATH", str(site))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    assert run_wsbuild("build", cwd=ws).returncode == 0
    time.sleep(SETTLE)
    recording = run_wsbuild("build", cwd=ws)
    assert recording.returncode == 0 and WARNING in recording.stdout + recording.stderr
    runs = Runs(ws, monkeypatch, capsys)
    code, out, replayed = runs.build()
    assert code == 0 and replayed and WARNING in out, "a replay repeats the warning"

    install_probe_distribution(site)
    code, out, replayed = runs.build()
    assert code == 0 and not replayed and WARNING not in out, out


def test_a_replayed_no_op_imports_no_command_line_and_starts_no_process(built: Path) -> None:
    """The real command, three times: the full no-op records, the next one is replayed by
    a process that imports neither the argument parser nor the planner (-X importtime)."""
    env = {**os.environ, "PYTHONPROFILEIMPORTTIME": "1"}
    # every variable but the terminal's and CI's reaches a package's record: the first build
    # in this environment builds again
    assert run_wsbuild("build", cwd=built, env=env).returncode == 0
    time.sleep(SETTLE)
    recording = run_wsbuild("build", cwd=built, env=env)
    assert recording.returncode == 0 and "wsbuild.cli" in recording.stderr
    replayed = run_wsbuild("build", cwd=built, env=env)
    assert replayed.returncode == 0, replayed.stderr
    assert replayed.stdout.splitlines()[1:] == recording.stdout.splitlines()[1:]
    imported = {line.rsplit("|", 1)[-1].strip() for line in replayed.stderr.splitlines()
                if line.startswith("import time:")}
    assert "wsbuild.engine.replay" in imported
    assert "wsbuild.reporter" in imported  # the one reporter draws what the no-op showed
    assert not imported & {"wsbuild.cli", "wsbuild.builder.plan", "subprocess",
                           "argparse"}, sorted(imported)


def test_list_is_replayed_while_the_workspace_is_unchanged(
        built: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """`list`, `graph` and `info` only read: an unchanged workspace's listing is printed from
    the record of the last one; a package added is listed by the full run that follows."""
    first = run_wsbuild("list", cwd=built)
    assert first.returncode == 0 and (built / replay.recording_path("list")).is_file()
    monkeypatch.chdir(built)
    os.environ.pop(PYTEST_VARIABLE, None)
    assert replay.replay(["list"], launch._drawing) == 0
    assert capsys.readouterr().out == first.stdout
    assert replay.replay(["graph"], launch._drawing) is None, "each verb has its own record"
    assert replay.replay(["list", "--topological-order"], launch._drawing) is None

    write_package(built / "src", "pn", "cmake")
    assert replay.replay(["list"], launch._drawing) is None
    again = run_wsbuild("list", cwd=built)
    assert again.returncode == 0 and "pn" in again.stdout
    failing = run_wsbuild("list", "--packages-select", "nothing_here", cwd=built)
    assert failing.returncode == 2
    assert not (built / replay.recording_path("list")).read_text().count("nothing_here"), \
        "a failed run leaves no record"


def test_a_damaged_record_means_a_full_run(recorded: tuple[Path, Runs]) -> None:
    ws, runs = recorded
    path = ws / replay.recording_path("build")
    record = json.loads(path.read_text())
    record["paths"] = [["/", "not a list of names", 3]]
    path.write_text(json.dumps(record))
    code, out, replayed = runs.build()
    assert code == 0 and not replayed and "2 packages up to date" in out
    path.write_text("{not json")
    assert runs.build()[2] is False


def test_a_reader_that_stops_early_gets_no_error_and_leaves_no_short_record(
        make_workspace: Callable[..., Path]) -> None:
    """`wsbuild list | true`: neither a replay nor the full run complains, and a full run whose
    output was cut short leaves no record (a verb that prints as it goes would have printed
    only part of its answer, and a later `wsbuild list > file` must get all of it)."""
    names = [f"pkg_{index:03d}" for index in range(300)]
    ws = make_workspace({name: ("cmake", []) for name in names})
    environ = {k: v for k, v in os.environ.items() if k != PYTEST_VARIABLE}
    record = ws / replay.recording_path("list")

    def shell(pipe: str) -> subprocess.CompletedProcess[str]:
        """`wsbuild list` run as a user's shell runs it (bash sets PWD, part of the key)."""
        done = subprocess.run(["bash", "-o", "pipefail", "-c",
                               f"{sys.executable} -m wsbuild list{pipe}"], cwd=ws,
                              env=environ, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0 and done.stderr == "", done.stderr
        return done

    shell("")  # makes build/: too recent to be recorded
    time.sleep(SETTLE)
    complete = shell("")
    assert [line.split()[0] for line in complete.stdout.splitlines()] == names
    assert record.is_file()
    shell(" | true")  # replayed: the reader is gone before it writes
    record.unlink()
    shell(" | true")  # in full
    assert not record.exists(), "a run whose output was cut short is not replayed"
    assert shell("").stdout == complete.stdout


def test_a_replayed_no_op_is_drawn_by_the_reporter_as_the_full_run_showed_it(
        built: Path) -> None:
    """The record keeps what the reporter was asked to show (its console options, the
    package list, the events), not the text: the replay asks the reporter again, so the
    output is the full run's, with the replay's own time."""
    args = ("build", "--event-handlers", "console_package_list+")
    full = run_wsbuild(*args, cwd=built)
    assert full.returncode == 0, full.stderr
    assert full.stdout.startswith("Topological order\n- pa (ament_python)\n"), full.stdout
    time.sleep(SETTLE)
    recording = run_wsbuild(*args, cwd=built)
    record = json.loads((built / replay.recording_path("build")).read_text())
    replayed = run_wsbuild(*args, cwd=built)

    assert [kind for kind, _ in record["shown"]][:2] == ["reporter", "package_list"]
    assert record["stdout"] == "" and record["stderr"] == ""
    assert replayed.returncode == 0, replayed.stderr
    summary = [line for line in replayed.stdout.splitlines() if line.startswith("Summary:")]
    assert len(summary) == 1 and summary[0].endswith("s]")
    strip = (lambda text: [line for line in text.splitlines()
                           if not line.startswith("Summary:")])
    assert strip(replayed.stdout) == strip(recording.stdout) == strip(full.stdout)


def test_a_recorder_that_fails_is_a_warning_and_the_next_run_is_full(
        recorded: tuple[Path, Runs]) -> None:
    """Issue 38: the recorder is handed down (no module global, nothing swapped in
    sys.stdout); when it fails, the run stands, says so in one warning and leaves no record,
    so the next run is a full one."""
    from wsbuild.engine import recording

    ws, runs = recorded
    record = ws / replay.recording_path("build")
    record.unlink()
    streams = (sys.stdout, sys.stderr)

    def broken(self: object, outcome: object) -> None:
        raise RuntimeError("the recorder's own bug")

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(recording.ReplayRecorder, "_paths", broken)
        code, out, replayed = runs.build()
    assert (sys.stdout, sys.stderr) == streams, "the run swapped the process's streams"
    assert code == 0 and not replayed and "2 packages up to date" in out, out
    warnings = [line for line in out.splitlines() if line.startswith("wsbuild: warning:")]
    assert warnings == ["wsbuild: warning: this run was not kept for replaying the next one "
                        "(RuntimeError: the recorder's own bug); the next run is a full one"]
    assert not record.exists()
    time.sleep(SETTLE)
    code, out, replayed = runs.build()
    assert code == 0 and not replayed and "2 packages up to date" in out
    assert record.is_file()
    assert runs.build()[2] is True


def test_another_build_of_wsbuild_runs_the_full_build(built: Path, tmp_path: Path) -> None:
    """The code of wsbuild that ran is an input of a recorded no-op: after an upgrade that
    kept the version number (here: one of its files replaced by a copy), the next no-op is a
    full run, not the last one's answer. Run from a copy of wsbuild, so no other test sees
    the change."""
    import shutil

    import wsbuild

    copy = tmp_path / "code"
    shutil.copytree(Path(wsbuild.__file__).parent, copy / "wsbuild",
                    ignore=shutil.ignore_patterns("__pycache__"))
    program = (f"import sys; sys.path.insert(0, {str(copy)!r}); sys.argv = ['wsbuild', 'build']; "
               "from wsbuild.launch import main; raise SystemExit(main())")
    env = {**os.environ, "PYTHONPROFILEIMPORTTIME": "1"}

    def build() -> tuple[str, set[str]]:
        done = subprocess.run([sys.executable, "-c", program], cwd=built, env=env,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        imported = {line.rsplit("|", 1)[-1].strip() for line in done.stderr.splitlines()
                    if line.startswith("import time:")}
        return done.stdout, imported

    build()  # the first build in this environment (another code path) builds again
    time.sleep(SETTLE)
    build()
    _, imported = build()
    assert "wsbuild.cli" not in imported, "the no-op of the same code is replayed"
    planned = copy / "wsbuild" / "builder" / "plan.py"
    planned.write_text(planned.read_text() + "\n# another build of wsbuild\n")
    out, imported = build()
    assert "wsbuild.cli" in imported, "replayed after wsbuild's code changed"
    assert "2 packages up to date" in out, out
