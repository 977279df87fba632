"""`wsbuild build --dry-run`: the start order, why each package would build (the file, option or
dependency that changed) or is up to date, unresolved dependencies, the critical path, the
commands of each package that would build (pasted into a fresh shell, they build it); and
build/, install/, log/ stay exactly as they were."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
import subprocess
from collections.abc import Callable
from pathlib import Path

from conftest import SMALL_SPEC as SPEC, run_wsbuild, write_package
from test_build_helpers import clean_env, output

HELLO_CMAKE = """cmake_minimum_required(VERSION 3.14)
project(hello C)
add_executable(hello hello.c)
install(TARGETS hello DESTINATION bin)
install(FILES package.xml DESTINATION share/hello)
"""
HELLO_C = '#include <stdio.h>\nint main(void) { puts("hello from C"); return 0; }\n'


def snapshot(ws: Path) -> dict[str, tuple[object, ...]]:
    """Every entry of build/, install/ and log/ with its type, size, mtime and content."""
    found: dict[str, tuple[object, ...]] = {}
    for base in ("build", "install", "log"):
        root = ws / base
        if not os.path.lexists(root):
            continue
        for dirpath, dirnames, filenames in os.walk(root):
            for name in [".", *dirnames, *filenames]:
                path = os.path.normpath(os.path.join(dirpath, name))
                info = os.lstat(path)
                if stat.S_ISLNK(info.st_mode):
                    content: object = os.readlink(path)
                elif stat.S_ISREG(info.st_mode):
                    content = hashlib.sha256(Path(path).read_bytes()).hexdigest()
                else:
                    content = None
                found[os.path.relpath(path, ws)] = (info.st_mode, info.st_size,
                                                    info.st_mtime_ns, content)
    return found


def _plan(ws: Path, *args: str) -> dict:  # type: ignore[type-arg]
    result = run_wsbuild("build", "--dry-run", "--json", *args, cwd=ws)
    assert result.returncode == 0, result.stdout + result.stderr
    return json.loads(result.stdout)


def test_the_dry_run_prints_the_plan_and_its_commands_only_when_asked(built: Path) -> None:
    """`--dry-run` is the plan (a few lines); the commands, each with its long environment,
    come with `--commands`, and the plan says so."""
    (built / "src" / "pa" / "pa" / "main.py").write_text("def main():\n    print('again')\n")
    plain = run_wsbuild("build", "--dry-run", cwd=built)
    assert plain.returncode == 0, plain.stderr
    lines = plain.stdout.splitlines()
    assert not any(line.lstrip().startswith("cd ") for line in lines), plain.stdout
    assert lines[-1] == ("commands: `wsbuild build --dry-run --commands` prints those that "
                         "build 2 packages")
    full = run_wsbuild("build", "--dry-run", "--commands", cwd=built)
    assert full.stdout.startswith("\n".join(lines[:-1]))
    assert any(line.lstrip().startswith("cd ") for line in full.stdout.splitlines())
    assert len(lines) < 10


def test_an_edit_shows_the_file_and_the_dependents_it_drags_along(built: Path) -> None:
    (built / "src" / "pa" / "pa" / "main.py").write_text("def main():\n    print('edited')\n")
    before = snapshot(built)
    result = run_wsbuild("build", "--dry-run", "--commands", cwd=built)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0] == "dry run: 3 packages, 2 would build, 1 up to date (nothing was touched)"
    rows = [line.split(None, 2) for line in lines[1:4]]
    # the order the build starts them in: the up-to-date one (settled before any job), then
    # the ready queue's, critical path first
    assert [row[1] for row in rows] == ["pc", "pa", "pb"]
    assert rows[0][2] == "up to date"
    assert rows[1][2] == "build: source changed: pa/main.py"
    assert rows[2][2] == ("build: dependency pa is built first; this package only if what it "
                          "read of it changes")
    assert lines[4].startswith("critical path (about ") and lines[4].endswith(": pa → pb")
    assert snapshot(built) == before  # not one byte, not one mtime
    # and the build does what the dry run said
    real = run_wsbuild("build", cwd=built)
    assert real.returncode == 0, real.stderr
    started = [line.split()[-1] for line in real.stdout.splitlines()
               if line.startswith("Starting >>>")]
    assert started == ["pa"]  # pb reads nothing of pa while building: cut off, as said
    assert "1 package cut off (a dependency was rebuilt, nothing they build from changed): pb" \
        in real.stdout


def test_json_names_the_option_that_changed(built: Path) -> None:
    before = snapshot(built)
    plan = _plan(built, "--symlink-install", "--cmake-args", "-DFOO=1", "--")
    reasons = {p["name"]: p["reason"] for p in plan["packages"]}
    assert reasons["pa"]["kind"] == "options"
    assert reasons["pa"]["details"] == ["symlink_install: false → true"]
    assert reasons["pc"]["details"] == ["cmake_args: [] → [-DFOO=1]",
                                        "symlink_install: false → true"]
    assert plan["critical_path"]["packages"] == ["pa", "pb"]
    assert snapshot(built) == before


def test_up_to_date_workspace(built: Path) -> None:
    plan = _plan(built)
    assert [(p["name"], p["up_to_date"], p["reason"]) for p in plan["packages"]] == [
        ("pa", True, None), ("pc", True, None), ("pb", True, None)]
    assert plan["refusal"] is None and plan["unresolved"] == {}


def test_a_damaged_install_and_a_forced_build_are_reasons_too(built: Path) -> None:
    (built / "install" / "pc" / "share" / "pc" / "package.xml").unlink()
    plan = _plan(built)
    reasons = {p["name"]: p["reason"] for p in plan["packages"]}
    assert reasons["pc"]["kind"] == "install"
    assert reasons["pc"]["details"] == ["pc/share/pc/package.xml"]
    forced = _plan(built, "--force", "--packages-select", "pa")
    assert [(p["name"], p["reason"]["kind"]) for p in forced["packages"]] == [("pa", "forced")]


def test_a_workspace_never_built_gets_no_directories(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace(SPEC)
    plan = _plan(ws)
    assert {p["reason"]["text"] for p in plan["packages"]} == {"no previous build"}
    assert sorted(os.listdir(ws)) == ["src"]


def test_unresolved_dependencies_and_what_the_build_would_refuse(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pa": ("ament_python", []),
                         "pd": ("ament_python", ["pa"], {"build_depend": ["no_such_thing_xyz"]})})
    plan = _plan(ws)
    assert plan["unresolved"] == {"pd": ["no_such_thing_xyz"]}
    strict = run_wsbuild("build", "--dry-run", "--commands", "--strict-dependencies", cwd=ws)
    assert strict.returncode == 2
    assert "  pd: no_such_thing_xyz" in strict.stdout
    assert strict.stdout.rstrip().endswith(
        "the build would refuse to start: unresolved build dependencies (--strict-dependencies)")
    alone = run_wsbuild("build", "--dry-run", "--commands", "--packages-select", "pd", cwd=ws)
    assert alone.returncode == 2
    assert ("the build would refuse to start: workspace packages not built yet: "
            "pa (needed by pd)") in alone.stdout
    assert sorted(os.listdir(ws)) == ["src"]


def test_json_needs_dry_run(built: Path) -> None:
    result = run_wsbuild("build", "--json", cwd=built)
    assert result.returncode == 2
    assert "--json goes with --dry-run" in result.stderr


def _commands(stdout: str) -> list[str]:
    """The shell lines of the dry run's commands section."""
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("commands ("))
    section = []
    for line in lines[start + 1:]:
        if not line.startswith("  "):
            break
        section.append(line[2:])
    return section


def test_the_printed_commands_pasted_into_a_fresh_shell_build_the_packages(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pa": ("ament_python", [])})
    hello = write_package(ws / "src", "hello", "cmake")
    (hello / "CMakeLists.txt").write_text(HELLO_CMAKE)
    (hello / "hello.c").write_text(HELLO_C)
    first = run_wsbuild("build", cwd=ws, env=clean_env())
    assert first.returncode == 0, output(first)
    # gone as after `wsbuild clean`, but for what the build writes once (the lint stand-ins)
    for base in ("build", "install"):
        for name in ("hello", "pa"):
            shutil.rmtree(ws / base / name)
    # the build cache would restore both, and a restore has no commands to paste
    result = run_wsbuild("build", "--dry-run", "--commands", "--no-cache", cwd=ws, env=clean_env())
    assert result.returncode == 0, output(result)
    commands = _commands(result.stdout)
    assert "# hello" in commands and "# pa" in commands
    assert not any("jobserver" in line or "wsbuild-" in line for line in commands)
    assert not (ws / "install" / "hello").exists()  # a dry run still touches nothing

    pasted = subprocess.run(["bash", "-c", "set -e\n" + "\n".join(commands)], cwd=ws,
                            env=clean_env(), capture_output=True, text=True, timeout=300)
    assert pasted.returncode == 0, pasted.stdout + pasted.stderr
    ran = subprocess.run([str(ws / "install" / "hello" / "bin" / "hello")],
                         capture_output=True, text=True, timeout=30)
    assert ran.stdout == "hello from C\n"
    site = next((ws / "install" / "pa" / "lib").glob("python3*/site-packages"))
    assert (site / "pa" / "main.py").read_text() == \
        (ws / "src" / "pa" / "pa" / "main.py").read_text()
    assert (ws / "install" / "pa" / "lib" / "pa" / "pa_main").is_file()
    assert (ws / "install" / "pa" / "share" / "ament_index" / "resource_index" / "packages"
            / "pa").is_file()


def test_json_carries_the_same_commands_and_steps(make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace(SPEC)
    text = run_wsbuild("build", "--dry-run", "--commands", cwd=ws)
    assert text.returncode == 0, output(text)
    plan = _plan(ws)
    section = _commands(text.stdout)
    for package in plan["packages"]:
        start = section.index(f"# {package['name']}")
        assert section[start + 1:start + 1 + len(package["commands"])] == package["commands"]
    steps = {p["name"]: [(s["label"], s["in_process"]) for s in p["steps"] if not s["builder"]]
             for p in plan["packages"]}
    # in-process work is a labelled step too (a fresh build directory has no configure
    # record to forget; the isolated install is parked and staged around `cmake --install`)
    assert steps == {"pc": [("configure", False), ("configure record", True),
                            ("build", False), ("park install", True), ("install", False),
                            ("stage", True)],
                     "pa": [("configure", True), ("install", True), ("index", True)],
                     "pb": [("configure", True), ("install", True), ("index", True)]}
    # and so is the builder's own: the compiler cache's server where the compilers are
    # launched through one, no times to advance before a first build, register and commit
    configure = next(s for s in plan["packages"][0]["steps"] if not s["builder"])
    launched = any(a.startswith("-DCMAKE_C_COMPILER_LAUNCHER=") for a in configure["argv"])
    for package in plan["packages"]:
        labels = [s["label"] for s in package["steps"]]
        builders = [s["label"] for s in package["steps"] if s["builder"]]
        assert builders == [*(["start compiler cache"] if launched else []), "register",
                            "commit"]
        assert labels[-2:] == ["register", "commit"]
        assert all(s["in_process"] for s in package["steps"] if s["builder"])
    assert "  # (in wsbuild) commit the stage into install/, replacing the package's install " \
        "(no command)" in text.stdout.splitlines()
    assert configure["argv"][:2] == ["cmake", str(ws / "src" / "pc")]
    assert configure["cwd"] == str(ws / "build" / "pc")
    assert configure["env"] == {"PYTHONHASHSEED": "0"}
    # a fresh workspace: the commands name the lint stand-ins the first build writes
    assert any(line.startswith("note: the commands read ") for line in text.stdout.splitlines())
    assert sorted(os.listdir(ws)) == ["src"]


def test_an_up_to_date_workspace_has_no_commands(built: Path) -> None:
    result = run_wsbuild("build", "--dry-run", "--commands", cwd=built)
    assert result.returncode == 0, output(result)
    assert "commands (" not in result.stdout
    assert all("steps" not in p for p in _plan(built)["packages"])


def test_after_a_failed_build_the_dry_run_says_failed_and_every_reason(tmp_path: Path) -> None:
    """A build that failed is not one that was cut short; and the failure does not hide what
    else changed since the last good build (an option)."""
    ws = tmp_path / "ws"
    pkg = write_package(ws / "src", "wobbly", "cmake")
    (pkg / "CMakeLists.txt").write_text("cmake_minimum_required(VERSION 3.14)\nproject(wobbly "
                                        "NONE)\ninstall(FILES package.xml DESTINATION share)\n")
    assert run_wsbuild("build", cwd=ws).returncode == 0
    (pkg / "CMakeLists.txt").write_text("cmake_minimum_required(VERSION 3.14)\nproject(wobbly "
                                        "NONE)\ninstall(FILES package.xml\n")  # broken
    assert run_wsbuild("build", "--cmake-args", "-DX=1", cwd=ws).returncode == 1
    planned = run_wsbuild("build", "--dry-run", "--cmake-args", "-DX=1", cwd=ws)
    [row] = [line for line in planned.stdout.splitlines() if "wobbly  build:" in line]
    assert row.split("  ", 2)[-1].strip().startswith(
        "build: the previous build failed; and build options changed: "), planned.stdout
    assert "did not finish" not in planned.stdout
