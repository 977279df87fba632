"""The recipe of the `python` build type (and `ament_python`'s): a setup.py / setup.cfg /
pyproject.toml package, standards-based.

Recipe: `configure` learns what setup() would install (a warm helper runs setup.py with
setuptools patched to only report, see `wsbuild.build_types.pybuild.setup_py`); `install` either places those files
itself (the fast path) or, when setup.py customises the build (cmdclass, ext_modules, ...) or
the backend is not setuptools, builds a wheel through PEP 517 and installs it with
`installer`; `record` keeps the list of installed files in the build directory. Neither path
runs `setup.py install` or `setup.py develop`, and nothing is written into the source tree.
"""

from __future__ import annotations

import configparser
import os
import sys
from dataclasses import dataclass
from pathlib import Path

from wsbuild.build_types import PackageContext, ReadOutside, StepFailed
from wsbuild.build_types.pybuild.install import (
    InstallTarget,
    install_plan,
    install_wheel,
    link_verbatim_copies,
    python_version_of,
    scripts_relpath,
)
from wsbuild.build_types.pybuild.paths import site_packages_relpath
from wsbuild.build_types.pybuild.setup_py import (
    BuildSystem,
    SetupPlan,
    compile_bytecode,
    read_build_system,
    read_setup,
)
from wsbuild import inputs
from wsbuild.errors import WsbuildError

_PROJECT_FILES = ("setup.py", "setup.cfg", "pyproject.toml")


@dataclass(frozen=True, slots=True)
class PythonBuildPlan:
    """What `configure` decided: the backend, setup()'s plan (None for a non-setuptools
    backend) and whether the fast path applies."""

    build_system: BuildSystem
    setup: SetupPlan | None
    fallback_reasons: tuple[str, ...]

    @property
    def fast(self) -> bool:
        return self.setup is not None and not self.fallback_reasons and self.setup.fast


def python_executable(ctx: PackageContext) -> str:
    return ctx.options.python_executable or sys.executable


def origin_file(source_dir: Path) -> Path:
    """The file a user edits to change what gets installed (named in messages)."""
    for name in _PROJECT_FILES:
        if (source_dir / name).is_file():
            return source_dir / name
    return source_dir / "setup.py"


def configure(ctx: PackageContext) -> PythonBuildPlan:
    """Learn the backend and setup()'s arguments; decide between fast path and fallback."""
    source = ctx.source_dir.absolute()
    if not any((source / name).is_file() for name in _PROJECT_FILES):
        raise StepFailed(f"{source}: no setup.py, setup.cfg or pyproject.toml to build")
    try:
        build_system = read_build_system(source)
    except WsbuildError as exc:
        raise StepFailed(str(exc)) from None
    blocker = build_system.fast_path_blocker()
    if not build_system.is_setuptools:
        return PythonBuildPlan(build_system, None, (blocker or "",))
    _check_syntax(source / "setup.py", python_executable(ctx))
    setup = read_setup(source, ctx.build_dir.absolute(), environ=ctx.environ,
                       python_executable=python_executable(ctx), observe=ctx.observe)
    reasons = setup.fallback_reasons + ((blocker,) if blocker else ())
    if setup.ignored_install_options:
        ctx.warn(f"{source / 'setup.cfg'}: [install] options "
                 f"{', '.join(setup.ignored_install_options)} are ignored by wsbuild")
    return PythonBuildPlan(build_system, setup, reasons)


def _check_syntax(setup_py: Path, executable: str) -> None:
    """A setup.py that is no valid Python fails here, naming itself and the line: setuptools
    runs it from a string (`File "<string>", line 17`) under the interpreter's name. Only
    parsed, never run; only when the build's interpreter is this one (another version may
    accept other syntax: its own build then reports the error)."""
    if os.path.realpath(executable) != os.path.realpath(sys.executable):
        return
    try:
        source = inputs.read_bytes(setup_py)
    except OSError:  # none (setup.cfg, pyproject.toml), or unreadable: the build says so
        return
    try:
        compile(source, str(setup_py), "exec", dont_inherit=True)
    except SyntaxError as exc:
        shown = (exc.text or "").rstrip()
        raise StepFailed(f"{setup_py}:{exc.lineno}: {type(exc).__name__}: {exc.msg}"
                         + (f"\n    {shown.strip()}" if shown.strip() else "")) from None


def install(ctx: PackageContext, plan: PythonBuildPlan | None) -> None:
    """Install into the stage prefix: the fast path, or a PEP 517 wheel."""
    if plan is None:
        raise StepFailed("install needs the configure step to run first")
    target = install_target(ctx, plan)
    source = ctx.source_dir.absolute()  # symlinks must not depend on the working directory
    origin = origin_file(source)
    if plan.fast:
        assert plan.setup is not None
        to_compile = install_plan(plan.setup, source_dir=source, target=target, origin=origin)
        ctx.outputs.read_outside = _read_outside(ctx, plan.setup)
    else:
        to_compile = _install_built_wheel(ctx, plan, target, origin)
    if not target.symlink and not ctx.environ.get("PYTHONDONTWRITEBYTECODE"):
        # `setup.py install` byte-compiles (unless PYTHONDONTWRITEBYTECODE is set); the
        # .pyc files name the final install path, not the stage
        errors = compile_bytecode([(path, target.final(path)) for path in to_compile],
                                  environ=ctx.environ, python_executable=target.python_executable,
                                  observe=ctx.observe)
        for error in errors:
            ctx.warn(f"byte-compiling failed: {error}")


def _read_outside(ctx: PackageContext, setup: SetupPlan) -> ReadOutside:
    """What the fast path reads outside the package in wsbuild's own process, where no step
    is observed: the files it installs from outside the package directory (what setup.py
    itself read is observed in the helper, build_types/pybuild/setup_py.py)."""
    inside = tuple({f"{spelling(directory)}{os.sep}"
                    for directory in (ctx.source_dir, ctx.build_dir)
                    for spelling in (os.path.abspath, os.path.realpath)})

    def outside(paths: set[str]) -> tuple[str, ...]:
        # the package's own files (a symlink into it, too) are its record's own files
        return tuple(sorted({os.path.abspath(path) for path in paths
                             if not (os.path.abspath(path) + os.sep).startswith(inside)
                             and not (os.path.realpath(path) + os.sep).startswith(inside)}))

    read = {str(ctx.source_dir / f.source) for f in setup.files}
    read.update(str(ctx.source_dir / name) for entry in setup.data_files for name in entry.sources)
    return ReadOutside(files=outside(read))


def install_target(ctx: PackageContext, plan: PythonBuildPlan) -> InstallTarget:
    executable = python_executable(ctx)
    site = site_packages_relpath(ctx.options.python_executable or None)
    symlink = ctx.options.symlink_install
    setup = plan.setup
    if setup is not None and setup.name:
        option = setup.install_scripts
        if symlink and setup.develop_script_dir:
            option = setup.develop_script_dir
        dist_name = setup.name
    elif plan.build_system.is_setuptools:
        # setup.py could not be read; the real build will say why, but put the scripts
        # where setup.cfg wants them in case it succeeds
        option, dist_name = _scripts_option_from_setup_cfg(ctx.source_dir, symlink), ""
    else:
        option, dist_name = None, ""
    scripts = scripts_relpath(option, install_prefix=ctx.install_prefix, dist_name=dist_name,
                              python_version=python_version_of(site),
                              origin=ctx.source_dir / "setup.cfg")
    return InstallTarget(stage_prefix=ctx.stage_prefix, install_prefix=ctx.install_prefix,
                         site_packages=site, scripts_dir=scripts, python_executable=executable,
                         symlink=symlink)


def _install_built_wheel(ctx: PackageContext, plan: PythonBuildPlan, target: InstallTarget,
                         origin: Path) -> list[Path]:
    from installer.utils import parse_wheel_filename

    from wsbuild.build_types.pybuild.pep517 import (
        build_wheel)  # lazy: off builds with no wheel to make

    # a plan learnt from setup.py knows whether setup_requires is set
    known = plan.setup is not None and bool(plan.setup.name) \
        and "setup_requires" not in plan.fallback_reasons
    wheel = build_wheel(ctx.source_dir, ctx.build_dir, plan.build_system, run=ctx.run,
                        environ=ctx.environ, python_executable=target.python_executable,
                        setup_requires_known_empty=known)
    egg_info: Path | None = None
    basename: str | None = None
    if plan.build_system.is_setuptools:
        # setuptools' egg_info ran into the build directory (see wsbuild.build_types.pybuild.pep517); install it
        # instead of the wheel's .dist-info, as colcon's `setup.py install` would
        found = sorted(ctx.build_dir.glob("*.egg-info"))
        if len(found) == 1:
            egg_info = found[0]
            version = parse_wheel_filename(wheel.name).version
            basename = (f"{egg_info.name[:-len('.egg-info')]}-{version}"
                        f"-py{python_version_of(target.site_packages)}.egg-info")
    to_compile = install_wheel(wheel, target=target, egg_info=egg_info,
                               egg_info_basename=basename)
    if target.symlink:
        reasons = "; ".join(filter(None, plan.fallback_reasons)) or "it needs a real build"
        linked = 0
        if plan.setup is not None:
            linked = link_verbatim_copies(plan.setup, source_dir=ctx.source_dir.absolute(),
                                          target=target, origin=origin)
        ctx.warn(f"--symlink-install: {ctx.package.name} is built as a wheel ({reasons}); "
                 f"{linked} installed files that are verbatim copies of sources are symlinks, "
                 "the rest are copies")
        return []
    return to_compile


def _scripts_option_from_setup_cfg(source_dir: Path, symlink: bool) -> str | None:
    path = source_dir / "setup.cfg"
    if not path.is_file():
        return None
    parser = configparser.ConfigParser(interpolation=None)
    try:
        parser.read(path, encoding="utf-8")
    except configparser.Error:
        return None
    if symlink and parser.get("develop", "script_dir", fallback=None):
        return parser.get("develop", "script_dir")
    return parser.get("install", "install_scripts", fallback=None)
