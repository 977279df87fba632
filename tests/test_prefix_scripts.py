"""install/{local_setup,setup}.* sourced in real bash, dash and zsh."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest
from test_prefix_trees import (
    SHELL_EXT,
    SITE,
    clean_env,
    entries,
    install_workspace,
    shell_or_skip,
    source_and_dump,
)

from wsbuild.errors import WorkspaceError, WsbuildError
from wsbuild.prefix import ChainedUnderlay, underlays_from_environment, write_workspace_scripts

SHELLS = ["bash", "dash", "zsh"]

#: 'zed' sorts last but everything depends on it: dependency order must win over names
PACKAGES = {
    "zed": ("cmake", ()),
    "alpha": ("ament_python", ("zed", "rclpy")),
    "mid": ("ament_cmake", ("alpha",)),
}


def build(install: Path, *, merged: bool = False, underlays: tuple[ChainedUnderlay, ...] = ()) -> None:
    install_workspace(install, PACKAGES, merged=merged)
    write_workspace_scripts(install, merged=merged, underlays=underlays)


@pytest.fixture
def install(tmp_path: Path) -> Path:
    base = tmp_path / "ws" / "install"
    build(base)
    return base


@pytest.mark.parametrize("shell", SHELLS)
def test_setup_applies_packages_in_dependency_order(shell: str, install: Path) -> None:
    env, _ = source_and_dump(shell, install / f"setup.{SHELL_EXT[shell]}")

    assert entries(env, "COLCON_PREFIX_PATH") == [str(install)]
    # each package prepends, so the last one applied comes first
    assert entries(env, "AMENT_PREFIX_PATH") == [str(install / "mid"), str(install / "alpha")]
    assert entries(env, "CMAKE_PREFIX_PATH") == [str(install / "mid"), str(install / "zed")]
    assert entries(env, "LD_LIBRARY_PATH") == [str(install / "mid/lib"), str(install / "zed/lib")]
    assert entries(env, "PYTHONPATH") == [str(install / "mid" / SITE), str(install / "alpha" / SITE)]
    assert entries(env, "PATH") == [str(install / "zed/bin"), "/usr/bin", "/bin"]
    assert "COLCON_CURRENT_PREFIX" not in env


@pytest.mark.parametrize("shell", SHELLS)
def test_sourcing_twice_adds_no_duplicates(shell: str, install: Path) -> None:
    once, _ = source_and_dump(shell, install / f"setup.{SHELL_EXT[shell]}")
    twice, _ = source_and_dump(shell, install / f"setup.{SHELL_EXT[shell]}", times=2)

    for name in ("PATH", "AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "LD_LIBRARY_PATH", "PYTHONPATH"):
        assert twice[name] == once[name]
        assert len(set(entries(twice, name))) == len(entries(twice, name))


@pytest.mark.parametrize("shell", SHELLS)
def test_existing_entries_are_kept_and_not_repeated(shell: str, install: Path) -> None:
    zed_lib = str(install / "zed/lib")
    env, _ = source_and_dump(
        shell, install / f"setup.{SHELL_EXT[shell]}",
        env=clean_env(LD_LIBRARY_PATH=f"/opt/x/lib:{zed_lib}", PYTHONPATH=""),
    )

    assert entries(env, "LD_LIBRARY_PATH") == [str(install / "mid/lib"), "/opt/x/lib", zed_lib]
    # an empty variable gets no trailing separator (which Python would read as the cwd)
    assert env["PYTHONPATH"] == f"{install / 'mid' / SITE}:{install / 'alpha' / SITE}"


@pytest.mark.parametrize("shell", ["bash", "zsh"])
def test_bash_and_zsh_find_their_prefix_from_any_directory(shell: str, install: Path, tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere" / "deeper"
    elsewhere.mkdir(parents=True)
    relative = os.path.relpath(install / f"setup.{shell}", elsewhere)

    env, _ = source_and_dump(shell, relative, cwd=elsewhere)

    assert entries(env, "COLCON_PREFIX_PATH") == [str(install)]
    assert str(install / "zed/bin") in entries(env, "PATH")


def test_sh_uses_the_build_time_prefix_from_any_directory(install: Path, tmp_path: Path) -> None:
    env, _ = source_and_dump("dash", install / "setup.sh", cwd=tmp_path)

    assert entries(env, "COLCON_PREFIX_PATH") == [str(install)]


@pytest.mark.parametrize("shell", SHELLS)
def test_relocated_workspace_still_works(shell: str, install: Path, tmp_path: Path) -> None:
    moved = tmp_path / "moved" / "install"
    moved.parent.mkdir()
    shutil.move(str(install), str(moved))
    script = moved / f"setup.{SHELL_EXT[shell]}"
    # a plain sh script cannot find itself: colcon's convention is COLCON_CURRENT_PREFIX
    before = f"COLCON_CURRENT_PREFIX='{moved}'" if shell == "dash" else ""

    env, _ = source_and_dump(shell, script, before=before)

    assert entries(env, "AMENT_PREFIX_PATH") == [str(moved / "mid"), str(moved / "alpha")]
    assert not any(str(install) in value for value in env.values())


def test_sh_without_build_time_prefix_explains_what_to_do(install: Path, tmp_path: Path) -> None:
    moved = tmp_path / "moved"
    shutil.move(str(install), str(moved))
    completed = _run("dash", f". '{moved}/setup.sh'")

    assert completed.returncode != 0
    assert b"COLCON_CURRENT_PREFIX" in completed.stderr


@pytest.mark.parametrize("shell", SHELLS)
def test_odd_characters_in_the_install_path(shell: str, tmp_path: Path) -> None:
    install = tmp_path / "my ws 'quoted' $HOME \"dq\" `true` $(x)" / "install"
    build(install)
    marker = tmp_path / "x"

    env, _ = source_and_dump(shell, install / f"setup.{SHELL_EXT[shell]}", cwd=tmp_path)

    assert entries(env, "AMENT_PREFIX_PATH") == [str(install / "mid"), str(install / "alpha")]
    assert entries(env, "COLCON_PREFIX_PATH") == [str(install)]
    assert not marker.exists()


@pytest.mark.parametrize("shell", SHELLS)
def test_sourcing_runs_no_python_and_no_other_program(shell: str, install: Path, tmp_path: Path) -> None:
    # PATH holds only recording fakes: any external command would be logged or not found
    fake_bin = tmp_path / "fake bin"
    fake_bin.mkdir()
    log = tmp_path / "calls.log"
    for name in ("python", "python3", "dirname", "env", "uname"):
        script = fake_bin / name
        script.write_text(f"#!/bin/sh\necho {name} >> '{log}'\n")
        script.chmod(0o755)
    completed = _run(
        shell, f". '{install}/setup.{SHELL_EXT[shell]}'; echo \"PATH=$PATH\"",
        env={"PATH": str(fake_bin), "HOME": "/nonexistent"},
    )

    assert completed.returncode == 0, completed.stderr.decode()
    assert completed.stderr == b""
    assert not log.exists()
    assert f"PATH={install}/zed/bin:{fake_bin}".encode() in completed.stdout


@pytest.mark.parametrize("shell", SHELLS)
def test_leaves_no_helpers_behind(shell: str, install: Path) -> None:
    listing = "typeset -f; set" if shell != "dash" else "set"
    completed = _run(
        shell, f"set -u; . '{install}/setup.{SHELL_EXT[shell]}'; {listing}",
        env=clean_env(),
    )

    assert completed.returncode == 0, completed.stderr.decode()
    leftovers = [
        line for line in completed.stdout.decode().splitlines()
        if "_wsb_" in line and "EXECUTION_STRING" not in line
    ]
    assert leftovers == []


@pytest.mark.parametrize("shell", SHELLS)
def test_merged_layout(shell: str, tmp_path: Path) -> None:
    install = tmp_path / "install"
    build(install, merged=True)

    env, _ = source_and_dump(shell, install / f"setup.{SHELL_EXT[shell]}")

    assert entries(env, "AMENT_PREFIX_PATH") == [str(install)]
    assert entries(env, "CMAKE_PREFIX_PATH") == [str(install)]
    assert entries(env, "PYTHONPATH") == [str(install / SITE)]
    assert entries(env, "PATH") == [str(install / "bin"), "/usr/bin", "/bin"]
    assert (install / ".colcon_install_layout").read_text() == "merged\n"


def test_layout_change_is_refused(install: Path) -> None:
    with pytest.raises(WorkspaceError, match="isolated"):
        write_workspace_scripts(install, merged=True, underlays=[])


def test_markers_and_stable_rewrites(install: Path) -> None:
    assert (install / ".colcon_install_layout").read_text() == "isolated\n"
    assert (install / "COLCON_IGNORE").read_text() == ""
    stamps = {p: p.stat().st_mtime_ns for p in install.iterdir() if p.is_file()}

    written = write_workspace_scripts(install, merged=False, underlays=[])

    assert written == []
    assert {p: p.stat().st_mtime_ns for p in install.iterdir() if p.is_file()} == stamps


def _underlay(root: Path, name: str) -> Path:
    """A fake workspace whose local_setup.* records that it ran and extends two variables."""
    root.mkdir(parents=True)
    for ext in ("sh", "bash", "zsh"):
        (root / f"local_setup.{ext}").write_text(
            f'export UNDERLAY_LOG="${{UNDERLAY_LOG:-}} {name}.{ext}:$COLCON_CURRENT_PREFIX"\n'
            f'export AMENT_PREFIX_PATH="{root}${{AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}}"\n'
            f'export PATH="{root}/bin:$PATH"\n'
        )
    return root


@pytest.mark.parametrize("shell", SHELLS)
def test_setup_sources_underlays_lowest_priority_first(shell: str, tmp_path: Path) -> None:
    high = _underlay(tmp_path / "high ws", "high")
    low = _underlay(tmp_path / "low ws", "low")
    venv = tmp_path / "venv"
    install = tmp_path / "ws" / "install"
    build(install, underlays=(
        ChainedUnderlay(high, high),
        ChainedUnderlay(low, low),
        ChainedUnderlay(venv, None, (("AMENT_PREFIX_PATH", str(venv)), ("PATH", f"{venv}/bin"))),
    ))
    ext = SHELL_EXT[shell]

    env, _ = source_and_dump(shell, install / f"setup.{ext}")

    assert env["UNDERLAY_LOG"] == f" low.{ext}:{low} high.{ext}:{high}"
    assert entries(env, "AMENT_PREFIX_PATH") == [
        str(install / "mid"), str(install / "alpha"), str(high), str(low), str(venv)
    ]
    assert entries(env, "PATH")[:4] == [
        str(install / "zed/bin"), str(high / "bin"), str(low / "bin"), str(venv / "bin")
    ]
    assert "COLCON_CURRENT_PREFIX" not in env


@pytest.mark.parametrize("shell", SHELLS)
def test_local_setup_does_not_source_underlays(shell: str, tmp_path: Path) -> None:
    low = _underlay(tmp_path / "low", "low")
    install = tmp_path / "install"
    build(install, underlays=(ChainedUnderlay(low, low),))

    env, _ = source_and_dump(shell, install / f"local_setup.{SHELL_EXT[shell]}")

    assert "UNDERLAY_LOG" not in env
    assert str(low) not in env["AMENT_PREFIX_PATH"]


@pytest.mark.parametrize("shell", SHELLS)
def test_script_without_dsv_is_sourced_with_its_prefix(shell: str, install: Path) -> None:
    share = install / "alpha" / "share" / "alpha"
    for ext in ("sh", "bash"):
        (share / "hook" / f"custom.{ext}").write_text(
            f'export CUSTOM="{ext}:$COLCON_CURRENT_PREFIX"\n'
        )
    with (share / "package.dsv").open("a") as dsv:
        dsv.write("source;share/alpha/hook/custom.bash\nsource;share/alpha/hook/custom.sh\n")
    write_workspace_scripts(install, merged=False, underlays=[])

    env, _ = source_and_dump(
        shell, install / f"local_setup.{SHELL_EXT[shell]}",
        before="COLCON_CURRENT_PREFIX=; export COLCON_CURRENT_PREFIX",
    )

    # like colcon: the .bash variant in bash, the .sh one where no variant exists
    expected = "bash" if shell == "bash" else "sh"
    assert env["CUSTOM"] == f"{expected}:{install / 'alpha'}"
    assert env["COLCON_CURRENT_PREFIX"] == ""


@pytest.mark.parametrize("shell", SHELLS)
def test_dsv_values_are_never_executed(shell: str, install: Path, tmp_path: Path) -> None:
    share = install / "alpha" / "share" / "alpha"
    (share / "hook" / "odd.dsv").write_text(
        "set;ODD;$(touch pwned) `touch pwned2` 'q' \"d\"\n"
        "prepend-non-duplicate;ODD_PATH;/x/$(touch pwned3)\n"
    )
    with (share / "package.dsv").open("a") as dsv:
        dsv.write("source;share/alpha/hook/odd.dsv\n")
    write_workspace_scripts(install, merged=False, underlays=[])

    env, _ = source_and_dump(shell, install / f"setup.{SHELL_EXT[shell]}", cwd=tmp_path)

    assert env["ODD"] == "$(touch pwned) `touch pwned2` 'q' \"d\""
    assert env["ODD_PATH"] == "/x/$(touch pwned3)"
    assert not any(p.name.startswith("pwned") for p in tmp_path.iterdir())


def test_invalid_variable_name_in_a_dsv_is_rejected(install: Path) -> None:
    share = install / "alpha" / "share" / "alpha"
    (share / "package.dsv").write_text("prepend-non-duplicate;A=$(touch x);bin\n")

    with pytest.raises(WsbuildError, match="invalid environment variable name") as info:
        write_workspace_scripts(install, merged=False, underlays=[])
    assert info.value.path == share / "package.dsv"
    assert info.value.line == 1


def test_installed_package_with_unsafe_name_is_rejected(install: Path) -> None:
    odd = install / "$(touch x)"
    index = odd / "share" / "colcon-core" / "packages"
    index.mkdir(parents=True)
    (index / odd.name).write_text("")

    with pytest.raises(WsbuildError, match="invalid package name"):
        write_workspace_scripts(install, merged=False, underlays=[])


def test_underlays_from_environment_follow_colcon(tmp_path: Path) -> None:
    install = tmp_path / "ws" / "install"
    build(install)
    colcon_ws = _underlay(tmp_path / "colcon_ws", "c")
    opt_ros = _underlay(tmp_path / "opt_ros", "o")
    isolated = tmp_path / "iso" / "install"
    (isolated / "pkg").mkdir(parents=True)
    (isolated / ".colcon_install_layout").write_text("isolated\n")
    plain = tmp_path / "venv"  # on AMENT_PREFIX_PATH but no local_setup.*: skipped by colcon
    plain.mkdir()
    environ = {
        "COLCON_PREFIX_PATH": f"{install}:{colcon_ws}:{tmp_path / 'gone'}",
        "AMENT_PREFIX_PATH": f"{install / 'mid'}:{isolated / 'pkg'}:{plain}:{opt_ros}:{colcon_ws}",
    }

    underlays = underlays_from_environment(environ, install)

    assert underlays == [
        ChainedUnderlay(colcon_ws, colcon_ws),
        ChainedUnderlay(isolated, isolated),
        ChainedUnderlay(opt_ros, opt_ros),
    ]


def _run(
    shell: str, program: str, *, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(
        [shell_or_skip(shell), "-c", program], env=env if env is not None else clean_env(),
        capture_output=True, check=False, timeout=60,
    )
