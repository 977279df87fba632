"""wsbuild/deps/install.py with a recording stand-in for subprocess.run: one command per
installer, key by key when it fails, apt-get only with -y and privileges (the real installers
run in tests/test_deps.py)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from wsbuild.deps import install as install_module
from wsbuild.deps.install import install
from wsbuild.deps.needs import Need
from wsbuild.deps.plan import DepsPlan, Installer, Source, Step
from wsbuild.workspace.model import DepKind, Resolution

PYTHON = Path("/venv/bin/python3")


def step(key: str, installer: Installer, *packages: str,
         source: Source = Source.PYTHON) -> Step:
    return Step(Need(key, ("pkg",), (DepKind.EXEC,), Resolution.UNRESOLVED), source, installer,
                packages)


class Recorder:
    """Runs nothing; fails every command naming one of `failing`."""

    def __init__(self, *failing: str) -> None:
        self.failing = set(failing)
        self.commands: list[list[str]] = []

    def __call__(self, command: list[str], **_kwargs: object) -> subprocess.CompletedProcess[str]:
        self.commands.append(command)
        bad = self.failing.intersection(command)
        stderr = f"ERROR: No matching distribution found for {sorted(bad)[0]}\n" if bad else ""
        return subprocess.CompletedProcess(command, 1 if bad else 0, "", stderr)


def run_plan(steps: list[Step], recorder: Recorder, *, assume_yes: bool = True,
             repaired: list[Path] | None = None):  # type: ignore[no-untyped-def]
    plan = DepsPlan(tuple(s.need for s in steps), tuple(steps), (), ())
    return install(plan, venv=Path("/venv"), python=PYTHON, constraint=Path("/lock.txt"),
                   assume_yes=assume_yes, environ={}, run=recorder,
                   repair=lambda venv: repaired or [])


def test_one_pip_command_for_all_keys() -> None:
    recorder = Recorder()
    report = run_plan([step("python3-psutil", Installer.PIP, "psutil"),
                       step("sensor_msgs", Installer.PIP, "ros-jazzy-sensor-msgs",
                            source=Source.ROS_WHEEL)], recorder,
                      repaired=[Path("/venv/share/x.cmake")])
    assert recorder.commands == [[str(PYTHON), "-m", "pip", "install", "-c", "/lock.txt",
                                  "--", "psutil", "ros-jazzy-sensor-msgs"]]
    assert all(o.ok for o in report.outcomes)
    assert report.repaired == (Path("/venv/share/x.cmake"),)  # new wheels are repaired


def test_a_failing_key_does_not_stop_the_others() -> None:
    recorder = Recorder("nosuch")
    report = run_plan([step("python3-nosuch", Installer.PIP, "nosuch"),
                       step("python3-psutil", Installer.PIP, "psutil")], recorder)
    assert [c[-1] for c in recorder.commands] == ["psutil", "nosuch", "psutil"]
    (failed,) = report.failed
    assert failed.step.need.key == "python3-nosuch"
    assert failed.message.startswith("ERROR: No matching distribution found for nosuch (from: ")
    assert report.repaired == ()  # no ROS wheel came in


def test_apt_is_printed_not_run_without_yes() -> None:
    recorder = Recorder()
    report = run_plan([step("gnu-hello", Installer.APT, "hello", source=Source.ROSDEP)],
                      recorder, assume_yes=False)
    assert recorder.commands == []
    assert "apt-get runs only with -y" in report.failed[0].message


def test_apt_as_a_user_without_sudo_prints_the_sudo_command(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(install_module.os, "geteuid", lambda: 1000)
    monkeypatch.setattr(install_module.shutil, "which", lambda _name: None)
    recorder = Recorder()
    report = run_plan([step("gnu-hello", Installer.APT, "hello", source=Source.ROSDEP)],
                      recorder)
    assert recorder.commands == []
    message = report.failed[0].message
    assert "apt-get needs root or password-less sudo" in message
    assert message.endswith("run it yourself: sudo apt-get install -y --no-install-recommends "
                            "-- hello")


def test_apt_with_password_less_sudo(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(install_module.os, "geteuid", lambda: 1000)
    monkeypatch.setattr(install_module.shutil, "which", lambda _name: "/usr/bin/sudo")
    recorder = Recorder()
    report = run_plan([step("gnu-hello", Installer.APT, "hello", source=Source.ROSDEP)],
                      recorder)
    # the run waits for dpkg's lock a bounded time (another apt-get may hold it)
    assert recorder.commands == [["sudo", "-n", "true"],
                                 ["sudo", "-n", "apt-get", "-o", "DPkg::Lock::Timeout=120",
                                  "install", "-y", "--no-install-recommends", "--", "hello"]]
    assert report.failed == []
