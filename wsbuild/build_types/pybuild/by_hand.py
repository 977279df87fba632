"""The steps of the `python` and `ament_python` recipes run from a shell, one process each:
`python -m wsbuild.build_types.pybuild.by_hand STEP --source DIR --build DIR --prefix DIR …`.

wsbuild runs these steps in its own process (a warm setup.py helper, files placed straight
into the stage); this is what `--dry-run` prints for them and what reproduces one by hand. It
runs the same functions, writing into the install prefix itself instead of a stage. `install`
reads setup.py again (what `configure` learnt is not kept between processes). A standalone
command like `setup_py_helper.py`: it prints its warnings and its error on stderr and sets its
own exit status (0 done, 1 the step failed).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from wsbuild.build_types import BuildContext, BuildOptions, Command, Problems, StepFailed

MODULE = "wsbuild.build_types.pybuild.by_hand"
STEPS = ("configure", "install", "index", "record")


def by_hand_command(step: str, ctx: BuildContext) -> Command:
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


def _context(args: argparse.Namespace, warnings: list[str]) -> BuildContext:
    import os

    from wsbuild.workspace.model import Package

    source = Path(args.source).absolute()
    build = Path(args.build).absolute()
    prefix = Path(args.prefix).absolute()
    build.mkdir(parents=True, exist_ok=True)
    prefix.mkdir(parents=True, exist_ok=True)
    manifest = Path(args.manifest).absolute() if args.manifest else None
    package = Package(args.name, source, "", manifest=manifest)
    options = BuildOptions(symlink_install=args.symlink_install,
                           python_executable=args.python or sys.executable)
    return BuildContext(package=package, build_dir=build, install_prefix=prefix,
                        stage_prefix=prefix, options=options, environ=dict(os.environ),
                        run=_run, warn=warnings.append)


def run_step(step: str, ctx: BuildContext) -> None:
    """One step of the recipe, into `ctx.stage_prefix`."""
    from wsbuild.build_types.ament_python import register
    from wsbuild.build_types.pybuild import recipe

    if step == "configure":
        recipe.configure(ctx)
    elif step == "install":
        recipe.install(ctx, recipe.configure(ctx))
    elif step == "index":
        register(ctx)
    else:
        recipe.record(ctx)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog=f"python -m {MODULE}",
                                     description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("step", choices=STEPS)
    parser.add_argument("--name", required=True, help="the package's name")
    parser.add_argument("--source", required=True, help="the package's source directory")
    parser.add_argument("--build", required=True, help="its build directory")
    parser.add_argument("--prefix", required=True, help="its install prefix")
    parser.add_argument("--manifest", help="its package.xml")
    parser.add_argument("--python", help="the interpreter to build for (default: this one)")
    parser.add_argument("--symlink-install", action="store_true")
    args = parser.parse_args(argv)
    warnings: list[str] = []
    try:
        run_step(args.step, _context(args, warnings))
    except StepFailed as exc:
        sys.stderr.write("".join(f"warning: {w}\n" for w in warnings) + f"error: {exc}\n")
        return 1
    finally:
        from wsbuild.build_types.pybuild.setup_py import shutdown_helpers

        shutdown_helpers()
    sys.stderr.write("".join(f"warning: {w}\n" for w in warnings))
    return 0


if __name__ == "__main__":
    sys.exit(main())
