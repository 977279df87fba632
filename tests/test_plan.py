"""One plan: what `build --dry-run` prints is what `build` then does, package by package, and
the commands it prints are the ones the build runs."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
from collections.abc import Callable
from pathlib import Path

from conftest import run_wsbuild, write_package

Run = subprocess.CompletedProcess[str]


def _env(xdg: Path) -> dict[str, str]:
    """A local build cache of the test's own in `xdg`."""
    env = {**os.environ, "XDG_CACHE_HOME": str(xdg), "WSBUILD_CACHE": ""}
    env.pop("WSBUILD_CACHE_DIR", None)
    return env


def _planned(ws: Path, env: dict[str, str]) -> dict[str, str]:
    result = run_wsbuild("build", "--dry-run", "--json", cwd=ws, env=env)
    assert result.returncode == 0, result.stdout + result.stderr
    return {p["name"]: "build unless cut off" if (p["reason"] or {}).get("cutoff")
            else p["decision"] for p in json.loads(result.stdout)["packages"]}


def _done(result: Run) -> dict[str, str]:
    """What the build did, by package, from its console lines and summary."""
    done = {name: "restore" for name in re.findall(r"^Restored <<< (\S+)", result.stdout, re.M)}
    done.update({name: "build" for name in re.findall(r"^Finished <<< (\S+)", result.stdout,
                                                       re.M)})
    return done


def test_every_decision_the_dry_run_prints_is_what_the_build_does(
        make_workspace: Callable[..., Path], tmp_path: Path) -> None:
    ws = make_workspace({"base": ("ament_python", []), "mid": ("ament_python", ["base"]),
                         "top": ("ament_python", ["mid"]), "side": ("cmake", []),
                         "lone": ("ament_python", [])})
    env = _env(tmp_path / "xdg")
    first = run_wsbuild("build", cwd=ws, env=env)
    assert first.returncode == 0, first.stdout + first.stderr

    # a changed workspace: an edited source (mid, and top through it), a removed build (side:
    # in the cache, so restored), a new package, and packages nothing touched (base, lone)
    (ws / "src" / "mid" / "mid" / "main.py").write_text("def main():\n    print('changed')\n")
    subprocess.run(["rm", "-rf", str(ws / "build" / "side"), str(ws / "install" / "side")],
                   check=True)
    write_package(ws / "src", "fresh", "ament_python", ["base"])

    planned = _planned(ws, env)
    # top's build reads nothing of mid: once mid is built, it is cut off (early cutoff)
    assert planned == {"base": "up to date", "lone": "up to date", "mid": "build",
                       "top": "build unless cut off", "side": "restore", "fresh": "build"}
    built = run_wsbuild("build", cwd=ws, env=env)
    assert built.returncode == 0, built.stdout + built.stderr
    done = _done(built)
    assert done == {name: d for name, d in planned.items()
                    if d not in ("up to date", "build unless cut off")}
    assert "3 packages up to date" in built.stdout
    assert "1 package cut off (a dependency was rebuilt, nothing they build from changed): " \
        "top" in built.stdout

    # and now the plan is a no-op, which the build confirms
    assert set(_planned(ws, env).values()) == {"up to date"}
    again = run_wsbuild("build", cwd=ws, env=env)
    assert again.returncode == 0 and _done(again) == {}


def _invoked(ws: Path, name: str) -> list[str]:
    """The commands the latest build ran for `name`, as its command.log shows them."""
    log = (ws / "log" / "latest_build" / name / "command.log").read_text()
    return [line.split(": ", 1)[1] for line in log.splitlines()
            if line.startswith("Invoking command in ")]


def test_the_commands_the_dry_run_prints_are_the_ones_the_build_runs(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pc": ("cmake", []), "pa": ("ament_python", [])})
    first = run_wsbuild("build", cwd=ws)
    assert first.returncode == 0, first.stdout + first.stderr
    # a changed CMake argument configures again: the dry run and the build agree on that too
    # (the in-process steps are in the plan too, labelled; only the commands are invoked)
    isolated_install = ["park install", "install", "stage"]
    for args, labels in ((["--cmake-args", "-DWSB_TEST_FLAG=1", "--"],
                          ["forget configure", "configure", "configure record", "build",
                           *isolated_install]),
                         (["--cmake-args", "-DWSB_TEST_FLAG=1", "--", "--force"],
                          ["build", *isolated_install])):
        planned = run_wsbuild("build", "--dry-run", "--json", *args, cwd=ws)
        assert planned.returncode == 0, planned.stdout + planned.stderr
        steps = {p["name"]: p.get("steps") for p in json.loads(planned.stdout)["packages"]}
        assert [s["label"] for s in steps["pc"] if not s["builder"]] == labels
        # the builder's own steps around them: a package built before has times to advance
        assert [s["label"] for s in steps["pc"] if s["builder"]][-3:] == \
            ["advance times", "register", "commit"]
        built = run_wsbuild("build", *args, cwd=ws)
        assert built.returncode == 0, built.stdout + built.stderr
        invoked = _invoked(ws, "pc")
        commands = [step for step in steps["pc"] if not step["in_process"]]
        assert len(invoked) == len(commands)
        for line, step in zip(invoked, commands):
            assert line.startswith(f"cd {shlex.quote(step['cwd'])} && ")
            assert line.endswith(" " + shlex.join(step["argv"])), (line, step["argv"])


def test_the_dry_run_lists_packages_in_the_order_a_one_worker_build_starts_them(
        make_workspace: Callable[..., Path]) -> None:
    """Both take the order from one ready queue (engine/ready_queue.py): the up-to-date ones
    first (settled before any job), then critical path first — not the name order."""
    ws = make_workspace({"lib_a": ("ament_python", []), "lib_b": ("ament_python", []),
                         "app": ("ament_python", ["lib_b"]), "tool": ("ament_python", []),
                         "extra": ("ament_python", [])})
    first = run_wsbuild("build", cwd=ws)
    assert first.returncode == 0, first.stdout + first.stderr
    # the weights the next build goes by: lib_b → app is the critical path
    (ws / "build" / ".wsbuild" / "durations.json").write_text(json.dumps(
        {"lib_a": 1, "lib_b": 30, "app": 20, "tool": 5, "extra": 1}))
    for name in ("lib_a", "lib_b", "app", "tool"):
        (ws / "src" / name / name / "main.py").write_text("def main():\n    print('edited')\n")

    planned = run_wsbuild("build", "--dry-run", "--json", cwd=ws)
    assert planned.returncode == 0, planned.stdout + planned.stderr
    order = [(p["name"], p["decision"]) for p in json.loads(planned.stdout)["packages"]]
    assert order == [("extra", "up to date"), ("lib_b", "build"), ("app", "build"),
                     ("tool", "build"), ("lib_a", "build")]
    built = run_wsbuild("build", "--executor", "sequential", cwd=ws)
    assert built.returncode == 0, built.stdout + built.stderr
    started = re.findall(r"^Starting >>> (\S+)", built.stdout, re.M)
    assert started == [name for name, decision in order if decision == "build"]


def test_a_build_types_steps_read_nothing_and_run_nothing(tmp_path: Path,
                                                          monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Issue 38: `steps()` is pure. What it decides from comes in the context: the run's facts
    (Ninja and its version, `run_facts`) and the build directory's state (`read_state`), read
    when the context was made. Called again with every file and process function failing,
    each built-in type returns the same steps."""
    import builtins
    import shutil

    from wsbuild.build_types import BuildOptions, get_build_type, package_context
    from wsbuild.workspace.manifest import parse_manifest

    build_types = ("cmake", "ament_cmake", "python", "ament_python")
    contexts = {}
    for kind in build_types:
        path = write_package(tmp_path / "src", f"pkg_{kind}", kind)
        package = parse_manifest(path / "package.xml", environ=os.environ,
                                 known_build_types=build_types)
        build_type = get_build_type(kind)
        build = tmp_path / "build" / package.name
        (build / "CMakeFiles").mkdir(parents=True)
        (build / "CMakeCache.txt").write_text("CMAKE_GENERATOR:INTERNAL=Unix Makefiles\n")
        facts = getattr(build_type, "run_facts", lambda _env: None)(dict(os.environ))
        contexts[kind] = (build_type, package_context(
            build_type, package=package, build_dir=build,
            install_prefix=tmp_path / "install" / package.name,
            stage_prefix=tmp_path / "stage" / package.name,
            options=BuildOptions(jobs=2, python_executable=shutil.which("python3") or ""),
            environ=dict(os.environ), run=lambda *a, **k: None, warn=lambda _t: None,
            facts=facts))
    first = {kind: bt.steps(ctx)
             for kind, (bt, ctx) in contexts.items()}

    def refused(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("steps() touched the disk or ran a process")

    for module, name in ((os, "stat"), (os, "lstat"), (os, "scandir"), (os, "listdir"),
                         (os, "open"), (builtins, "open"), (subprocess, "run"),
                         (subprocess, "Popen"), (shutil, "which")):
        monkeypatch.setattr(module, name, refused)
    again = {kind: bt.steps(ctx)
             for kind, (bt, ctx) in contexts.items()}
    monkeypatch.undo()
    assert again == first
    # the CMake cache of another generator came in the state: its removal is a step
    assert [step.label for step in first["cmake"]][:2] == ["clean cache", "configure"]
