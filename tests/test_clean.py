"""`wsbuild clean`: removes what builds left, of the selected packages or all, asks first, keeps
the rest sourceable, and never deletes outside the workspace's own build/install/log."""

from __future__ import annotations

import os
import pty
import select
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from conftest import SMALL_SPEC as SPEC, run_wsbuild


def _tree(root: Path) -> list[str]:
    """Every path under `root` (links not followed), to show what a command left alone."""
    found = []
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            found.append(os.path.relpath(os.path.join(dirpath, name), root))
    return sorted(found)


def _sourced_prefixes(ws: Path) -> list[str]:
    script = 'set -u; source install/setup.bash; printf "%s\\n" "$AMENT_PREFIX_PATH"'
    result = subprocess.run(["bash", "-c", script], cwd=ws, capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0, result.stderr
    return [p for p in result.stdout.strip().split(":") if p.startswith(str(ws))]


def test_clean_a_selected_package_keeps_the_rest_sourceable(built: Path) -> None:
    setup_before = (built / "install" / "setup.bash").read_bytes()
    result = run_wsbuild("clean", "--packages-select", "pb", "-y", cwd=built)
    assert result.returncode == 0, result.stderr
    listed = result.stdout.splitlines()
    assert listed[0] == "wsbuild clean will delete 3 entries:"
    assert listed[1:3] == ["  build/pb/", "  install/pb/"]
    assert listed[3].startswith("  log/build_") and listed[3].endswith("/pb/")
    assert not (built / "build" / "pb").exists() and not (built / "install" / "pb").exists()
    assert not list((built / "log").glob("*/pb"))
    for name in ("pa", "pc"):
        assert (built / "build" / name).is_dir() and (built / "install" / name).is_dir()
    # local_setup.* lost pb; setup.* (the underlay chain) is as the build wrote it
    assert (built / "install" / "setup.bash").read_bytes() == setup_before
    assert sorted(_sourced_prefixes(built)) == [str(built / "install" / n) for n in ("pa", "pc")]
    rebuilt = run_wsbuild("build", cwd=built)
    assert rebuilt.returncode == 0, rebuilt.stderr
    # pb comes back (from the build cache: it is what was built there before), nothing else
    assert [line.split()[2] for line in rebuilt.stdout.splitlines()
            if line.startswith(("Starting", "Restored"))] == ["pb"]


def test_build_install_and_log_pick_what_goes(built: Path) -> None:
    result = run_wsbuild("clean", "--packages-select", "pa", "--install", "-y", cwd=built)
    assert result.returncode == 0, result.stderr
    assert not (built / "install" / "pa").exists()
    assert (built / "build" / "pa").is_dir() and list((built / "log").glob("*/pa"))
    result = run_wsbuild("clean", "--build", "--log", "-y", cwd=built)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[1:] == ["  build/", "  log/", "deleted 2 entries"]
    assert sorted(os.listdir(built)) == ["install", "src"]


def test_without_selection_the_whole_workspace_is_cleaned(built: Path) -> None:
    sources = _tree(built / "src")
    result = run_wsbuild("clean", "-y", cwd=built / "src" / "pa")  # from inside the workspace
    assert result.returncode == 0, result.stderr
    assert sorted(os.listdir(built)) == ["src"]
    assert _tree(built / "src") == sources
    again = run_wsbuild("clean", "-y", cwd=built)
    assert (again.returncode, again.stdout) == (0, "nothing to clean\n")


def test_without_a_terminal_it_refuses_unless_told_yes(built: Path) -> None:
    before = _tree(built)
    result = subprocess.run([sys.executable, "-m", "wsbuild", "clean"], cwd=built,
                            stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert "  build/" in result.stdout  # what would have gone is still listed
    assert ("wsbuild: error: refusing to delete without asking: stdin is not a terminal "
            "(pass -y to delete without asking)") in result.stderr
    assert _tree(built) == before


def _in_terminal(ws: Path, answer: str, *args: str) -> tuple[int, str]:
    """Run `wsbuild clean ARGS` on a pseudo-terminal and answer its question."""
    master, slave = pty.openpty()
    process = subprocess.Popen([sys.executable, "-m", "wsbuild", "clean", *args], cwd=ws,
                               stdin=slave, stdout=slave, stderr=slave)
    os.close(slave)
    output = b""
    answered = False
    deadline = time.monotonic() + 60
    try:
        while time.monotonic() < deadline:
            ready, _, _ = select.select([master], [], [], 0.2)
            if ready:
                try:
                    chunk = os.read(master, 4096)
                except OSError:  # EIO: the other side closed
                    break
                if not chunk:
                    break
                output += chunk
            if not answered and b"[y/N]" in output:
                os.write(master, answer.encode() + b"\n")
                answered = True
        return process.wait(timeout=30), output.decode(errors="replace")
    finally:
        os.close(master)
        if process.poll() is None:
            process.kill()


def test_on_a_terminal_it_asks_first(built: Path) -> None:
    before = _tree(built)
    code, output = _in_terminal(built, "n", "--packages-select", "pa")
    assert code == 0 and "Delete these? [y/N]" in output and "nothing deleted" in output
    assert _tree(built) == before
    code, output = _in_terminal(built, "y", "--packages-select", "pa")
    assert code == 0 and "deleted 3 entries" in output, output
    assert not (built / "install" / "pa").exists()


def test_a_symlink_leading_out_of_a_base_is_refused_and_nothing_is_deleted(
        built: Path, tmp_path: Path) -> None:
    outside = tmp_path / "precious"
    outside.mkdir()
    (outside / "keep.txt").write_text("keep me")
    install_pa = built / "install" / "pa"
    os.rename(install_pa, tmp_path / "pa_install")
    install_pa.symlink_to(outside)
    before = _tree(built)
    result = run_wsbuild("clean", "--packages-select", "pa", "-y", cwd=built)
    assert result.returncode == 2
    assert (f"wsbuild: error: {install_pa}: refusing to clean a symbolic link leading out of "
            f"{built / 'install'} (it points to {outside})") in result.stderr
    assert (outside / "keep.txt").read_text() == "keep me"
    assert _tree(built) == before and _tree(outside) == ["keep.txt"]


@pytest.mark.parametrize(("base", "problem"), [
    ("../elsewhere", "refusing to clean a directory outside the workspace"),
    ("src", "refusing to clean a directory that holds sources"),
    ("notes", "refusing to clean a directory without the COLCON_IGNORE marker"),
    ("linked", "refusing to clean through a symbolic link"),
])
def test_bases_that_are_not_the_workspaces_own_are_refused(built: Path, base: str,
                                                           problem: str) -> None:
    (built.parent / "elsewhere").mkdir()
    (built.parent / "elsewhere" / "COLCON_IGNORE").touch()
    (built / "notes").mkdir()
    (built / "notes" / "todo.txt").write_text("x")
    (built / "linked").symlink_to(built.parent / "elsewhere")
    before, elsewhere = _tree(built), _tree(built.parent / "elsewhere")
    # (with src/ as the build base, discovery skips src/: there is no package to select)
    for selection in ([], ["--packages-select", "pa"]) if base != "src" else ([],):
        result = run_wsbuild("clean", "--build-base", base, *selection, "-y", cwd=built)
        assert result.returncode == 2, result.stdout
        assert problem in result.stderr
    assert _tree(built) == before and _tree(built.parent / "elsewhere") == elsewhere


def test_a_merged_install_loses_only_the_packages_files(make_workspace: Callable[..., Path],
                                                        ) -> None:
    ws = make_workspace(SPEC)
    result = run_wsbuild("build", "--merge-install", cwd=ws)
    assert result.returncode == 0, result.stderr
    install = ws / "install"
    pb_files = (ws / "build" / "pb" / ".wsbuild" / "merged_files.txt").read_text().split()
    assert "share/pb/package.xml" in pb_files
    result = run_wsbuild("clean", "--packages-select", "pb", "--install", "-y", cwd=ws)
    assert result.returncode == 0, result.stderr
    assert not any((install / rel).exists() for rel in pb_files)
    assert not (install / "share" / "pb").exists()  # emptied directories go too
    assert (install / "share" / "pa" / "package.xml").is_file()
    script = 'source install/setup.bash; python3 -c "import pa" && ! python3 -c "import pb"'
    sourced = subprocess.run(["bash", "-c", script], cwd=ws, capture_output=True, text=True,
                             timeout=60)
    assert sourced.returncode == 0, sourced.stderr


def test_a_symlink_install_is_removed_without_following_its_links(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace(SPEC)
    result = run_wsbuild("build", "--symlink-install", cwd=ws)
    assert result.returncode == 0, result.stderr
    links = [p for p in (ws / "install").rglob("*") if p.is_symlink()]
    assert any(str(os.readlink(p)).startswith(str(ws / "src")) for p in links)
    sources = {p: p.read_bytes() for p in (ws / "src").rglob("*") if p.is_file()}
    for args in (["--packages-select", "pa", "-y"], ["-y"]):
        result = run_wsbuild("clean", *args, cwd=ws)
        assert result.returncode == 0, result.stderr
        assert {p: p.read_bytes() for p in (ws / "src").rglob("*") if p.is_file()} == sources
    assert sorted(os.listdir(ws)) == ["src"]
