"""The steps of the `python` and `ament_python` recipes run from a shell, one process each:
`python -m wsbuild.build_types.pybuild.by_hand STEP --source DIR --build DIR --prefix DIR …`.

wsbuild runs these steps in its own process (a warm setup.py helper, files placed straight
into the stage); this is what `--dry-run` prints for them and what reproduces one by hand. It
runs the same functions, writing into the install prefix itself instead of a stage. `install`
reads setup.py again (what `configure` learnt is not kept between processes). A standalone
command like `pep517_hook.py` (its arguments read the same plain way): it prints its warnings
and its error on stderr and sets its own exit status (0 done, 1 the step failed, 2 usage).
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from wsbuild.build_types import PackageContext, BuildOptions, Command, Problems, StepFailed
from wsbuild.build_types import get_build_type, package_context
from wsbuild.workspace.model import Package
from wsbuild.workspace.names import is_valid_dependency_name

MODULE = "wsbuild.build_types.pybuild.by_hand"
STEPS = ("configure", "install", "index")


def by_hand_command(step: str, ctx: PackageContext) -> Command:
    """The command that runs `step` of `ctx`'s package from a shell, in the workspace."""
    assert step in STEPS, step
    argv = [sys.executable, "-m", MODULE, step, "--name", ctx.package.name,
            "--source", str(ctx.source_dir.absolute()), "--build", str(ctx.build_dir),
            "--prefix", str(ctx.install_prefix)]
    if ctx.package.manifest is not None:
        argv += ["--manifest", str(ctx.package.manifest)]
    if ctx.options.python_executable not in ("", sys.executable):
        argv += ["--python", ctx.options.python_executable]
    if ctx.options.symlink_install:
        argv.append("--symlink-install")
    return Command(tuple(argv), ctx.source_dir.absolute())


def _run(command: Sequence[str], *, cwd: Path, env: Mapping[str, str] | None = None,
         problems: Problems | None = None) -> None:
    done = subprocess.run(list(command), cwd=cwd, env=None if env is None else dict(env),
                          stdin=subprocess.DEVNULL, check=False)
    if done.returncode != 0:
        raise StepFailed(f"'{command[0]}' exited with code {done.returncode}", command=command,
                         cwd=cwd, returncode=done.returncode)


#: the options that take a value, and the one flag
_VALUED = ("--name", "--source", "--build", "--prefix", "--manifest", "--python")
_FLAG = "--symlink-install"
USAGE = (f"usage: python -m {MODULE} {{{','.join(STEPS)}}} --name NAME --source DIR "
         "--build DIR --prefix DIR [--manifest FILE] [--python EXE] [--symlink-install]")


def _parse(argv: Sequence[str]) -> tuple[str, dict[str, str], bool] | None:
    """(step, option values, symlink install), or None when `argv` is not of that form."""
    if not argv or argv[0] not in STEPS:
        return None
    values: dict[str, str] = {}
    symlink = False
    rest = iter(argv[1:])
    for arg in rest:
        if arg == _FLAG:
            symlink = True
        elif arg in _VALUED:
            value = next(rest, None)
            if value is None:
                return None
            values[arg[2:]] = value
        else:
            return None
    if any(name not in values for name in ("name", "source", "build", "prefix")):
        return None
    if not is_valid_dependency_name(values["name"]):
        return None  # it names paths below the prefix: no separators, no leading dot
    return argv[0], values, symlink


def _context(values: Mapping[str, str], symlink: bool, warnings: list[str]) -> PackageContext:
    """The step's context, made by the function every context is made by
    (`build_types.package_context`), from the command line: the shell's environment is the
    package's (`--dry-run` prints the export line that sets it), the install goes straight
    into the prefix."""
    import os

    source = Path(values["source"]).absolute()
    build = Path(values["build"]).absolute()
    prefix = Path(values["prefix"]).absolute()
    build.mkdir(parents=True, exist_ok=True)
    prefix.mkdir(parents=True, exist_ok=True)
    manifest = Path(values["manifest"]).absolute() if "manifest" in values else None
    package = Package(values["name"], source, "python", manifest=manifest)
    options = BuildOptions(symlink_install=symlink,
                           python_executable=values.get("python") or sys.executable)
    return package_context(get_build_type("python"), package=package, build_dir=build,
                           install_prefix=prefix, stage_prefix=prefix, options=options,
                           environ=os.environ, run=_run, warn=warnings.append)


def run_step(step: str, ctx: PackageContext) -> None:
    """One step of the recipe, into `ctx.stage_prefix`."""
    from wsbuild.build_types.pybuild import recipe  # lazy: off `build --dry-run`
    from wsbuild.build_types.pybuild.index import register  # lazy: off `build --dry-run`

    if step == "configure":
        recipe.configure(ctx)
    elif step == "install":
        recipe.install(ctx, recipe.configure(ctx))
    else:
        register(ctx)


def main(argv: Sequence[str]) -> int:
    parsed = _parse(argv)
    if parsed is None:
        sys.stderr.write(USAGE + "\n")
        return 2
    step, values, symlink = parsed
    warnings: list[str] = []
    try:
        run_step(step, _context(values, symlink, warnings))
    except StepFailed as exc:
        sys.stderr.write("".join(f"warning: {w}\n" for w in warnings) + f"error: {exc}\n")
        return 1
    finally:
        from wsbuild.build_types.pybuild.setup_py import (
            shutdown_helpers)  # lazy: off `build --dry-run`

        shutdown_helpers()
    sys.stderr.write("".join(f"warning: {w}\n" for w in warnings))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
