"""The `cmake` build type: configure when needed, build, install. ament_cmake builds on it.

Generator: Ninja when a `ninja` executable is found (on the build environment's PATH or next
to wsbuild's interpreter, where `pip install ninja` puts it), unless `--cmake-args` name a
generator (`-G`) or `CMAKE_GENERATOR` is set; otherwise CMake's default (Unix Makefiles).
A build directory configured with another generator is configured again from scratch, and one
built for another install mode (ament's symlink install) is emptied first.
Both share the run's CPU budget: make through the jobserver's file descriptors, Ninja ≥ 1.13
through its named FIFO; an older Ninja gets a fixed `-j` of the budget.
The compiler cache chosen for the run (`compiler_launcher`) becomes
`CMAKE_<LANG>_COMPILER_LAUNCHER` for C and C++, unless `--cmake-args` set one. With
distributed compiles (builder/distribute.py) the launcher is ccache calling distcc, or distcc;
links and code generators then go through the local gate, whose CMake file the environment
names (`WSBUILD_LOCAL_GATE_CMAKE`, given to CMake as `CMAKE_PROJECT_INCLUDE`).
"""

from __future__ import annotations

import functools
import json
import os
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from wsbuild.build_types import (
    PackageContext,
    BuildOptions,
    Command,
    ReadOutside,
    RunnerNamed,
    Step,
    TypeOption,
    key_options,
)
from wsbuild.build_types.cmake_facts import (
    CONFIGURE_RECORD,
    CMakeFacts,
    CMakeState,
    NinjaTool,
    find_ninja,
    read_cmake_state,
    user_generator,
)
from wsbuild.build_types.cmake_options import CMAKE_OPTIONS, CMakeOptions
from wsbuild.prefix.hooks import EnvironmentHooks


NINJA = "Ninja"
#: CMake's default generator on this platform, when nobody chooses one
DEFAULT_GENERATOR = "Unix Makefiles"
LAUNCHED_LANGUAGES = ("C", "CXX")
#: the local gate's CMake file of a distributed build (builder/distribute.py)
LOCAL_GATE_VAR = "WSBUILD_LOCAL_GATE_CMAKE"
#: what a C/C++ toolchain reads from the environment at the first configure only: a change
#: configures from scratch
COMPILER_ENVIRONMENT = ("CC", "CXX", "CFLAGS", "CXXFLAGS", "CPPFLAGS", "LDFLAGS")
#: what wsbuild sets in a build's environment for one run only (the jobserver, the compiler
#: cache's and distcc's private files): not what a configure depends on
_RUN_ONLY_ENVIRONMENT = ("MAKEFLAGS", "CCACHE_*", "SCCACHE_*", "DISTCC_*")


def _compiler_digests(environ: Mapping[str, str]) -> dict[str, str | None]:
    """Each compiler variable by a digest of its value (None: unset)."""
    from wsbuild.record.environment import environment_digests

    digests = environment_digests({k: environ[k] for k in COMPILER_ENVIRONMENT if k in environ})
    return {name: digests.get(name) for name in COMPILER_ENVIRONMENT}


def _defines(cmake_args: Sequence[str], name: str) -> bool:
    return any(a.startswith((f"-D{name}=", f"-D{name}:")) for a in cmake_args)


def _manifest_files(ctx: PackageContext) -> list[str]:
    files: list[str] = []
    for name in ("install_manifest.txt", "symlink_install_manifest.txt"):
        path = ctx.build_dir / name
        if path.is_file():
            for line in path.read_text().splitlines():
                if line.strip() and Path(line).is_relative_to(ctx.install_prefix):
                    files.append(str(Path(line).relative_to(ctx.install_prefix)))
    return sorted(set(files))


def cmake_options(ctx: PackageContext) -> CMakeOptions:
    """The package's own CMake options (--cmake-args, …) as its context holds them."""
    return CMakeOptions.of(ctx.options)


@dataclass(frozen=True, slots=True)
class CMakeBuildType:
    name: str = "cmake"
    #: colcon-ros gives a plain CMake package with a package.xml its pkg-config paths
    hooks: EnvironmentHooks = EnvironmentHooks(cmake_prefix_path=True, pkg_config_path=True)
    estimate_base: float = 1.5
    test_runner = RunnerNamed("wsbuild.build_types.ctest:CTEST")

    #: --cmake-args, --cmake-target, … (cmake_options.py)
    options: tuple[TypeOption, ...] = CMAKE_OPTIONS

    def key_options(self, options: BuildOptions) -> dict[str, object]:
        return key_options(options, self.options)

    def run_facts(self, environ: Mapping[str, str]) -> CMakeFacts:
        return CMakeFacts(find_ninja(environ))

    def read_state(self, build_dir: Path) -> CMakeState:
        return read_cmake_state(build_dir)

    def steps(self, ctx: PackageContext) -> list[Step]:
        """Configure when needed (with what must go first and the record after it), build,
        install: decided from the context's facts and state, reading nothing."""
        steps = []
        if self.needs_configure(ctx):
            steps += self.prepare_configure_steps(ctx)
            steps.append(self.configure_step(ctx))
            steps.append(self.configure_record_step(ctx))
        steps.append(self.build_step(ctx))
        steps += self.install_steps(ctx)
        return steps

    def configure_args(self, ctx: PackageContext) -> list[str]:
        python = ctx.options.python_executable
        args = [
            # wsbuild passes Python hints every project may ignore: don't warn about them
            "--no-warn-unused-cli",
            *self.generator_args(ctx),
            f"-DCMAKE_INSTALL_PREFIX={ctx.install_prefix}",
            "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON",
            f"-DPYTHON_EXECUTABLE={python}",
        ]
        own = cmake_options(ctx)
        if not any(a.startswith("-DPython3_EXECUTABLE=") for a in own.underlay_args):
            args.append(f"-DPython3_EXECUTABLE={python}")
        args += self.launcher_args(ctx)
        return [*args, *own.underlay_args, *own.args]

    def ninja(self, ctx: PackageContext) -> NinjaTool | None:
        """The run's Ninja (its facts; found now for a context made without them)."""
        facts = ctx.facts if isinstance(ctx.facts, CMakeFacts) else self.run_facts(ctx.environ)
        return facts.ninja

    def state(self, ctx: PackageContext) -> CMakeState:
        """What the build directory held when the context was made."""
        return ctx.state if isinstance(ctx.state, CMakeState) else read_cmake_state(ctx.build_dir)

    def generator(self, ctx: PackageContext) -> str:
        """The generator this configure uses (the user's, else Ninja when found, else CMake's
        default)."""
        chosen = user_generator(cmake_options(ctx).args, ctx.environ)
        if chosen:
            return chosen
        return NINJA if self.ninja(ctx) is not None else DEFAULT_GENERATOR

    def generator_args(self, ctx: PackageContext) -> list[str]:
        args = []
        user = user_generator(cmake_options(ctx).args, ctx.environ)
        ninja = self.ninja(ctx)
        if user is None and ninja is not None:
            args += ["-G", NINJA]
        if ninja is not None and (user or NINJA) == NINJA \
                and not _defines(cmake_options(ctx).args, "CMAKE_MAKE_PROGRAM"):
            # the ninja whose version decided how it shares the CPU budget
            args.append(f"-DCMAKE_MAKE_PROGRAM={ninja.path}")
        return args

    def launcher_args(self, ctx: PackageContext) -> list[str]:
        """The compiler cache as C/C++ compiler launcher; without one, a launcher an earlier
        configure left in the cache is removed (the user's own --cmake-args always win)."""
        args = []
        for language in LAUNCHED_LANGUAGES:
            name = f"CMAKE_{language}_COMPILER_LAUNCHER"
            if _defines(cmake_options(ctx).args, name):
                continue
            if ctx.options.compiler_launcher:
                args.append(f"-D{name}={ctx.options.compiler_launcher}")
            else:
                args.append(f"-U{name}")
        gate = ctx.environ.get(LOCAL_GATE_VAR, "")
        if gate and not _defines(cmake_options(ctx).args, "CMAKE_PROJECT_INCLUDE"):
            args.append(f"-DCMAKE_PROJECT_INCLUDE={gate}")
        elif not gate and self._gate_configured(ctx):
            # a distributed build's gate goes away; kept in later records, so that a local
            # build after a distributed one configures once, not every time
            args.append("-UCMAKE_PROJECT_INCLUDE")
        return args

    def _gate_configured(self, ctx: PackageContext) -> bool:
        record = self.state(ctx).record
        previous = record.get("args", []) if record is not None else []
        return any(a == "-UCMAKE_PROJECT_INCLUDE" or (
            a.startswith("-DCMAKE_PROJECT_INCLUDE=") and a.endswith("local_gate.cmake"))
            for a in previous if isinstance(a, str))

    def build_environ(self, ctx: PackageContext) -> dict[str, str]:
        """The package environment for configure and build, plus: Ninja ≥ 1.13 joins the
        jobserver through its FIFO (it does not take the descriptor form make uses); and
        Python's string hashing is fixed unless the user chose a seed, so code generators that
        iterate over sets (rosidl's #include lists) write the same files every time: compiler
        cache hits, reproducible builds."""
        env = dict(ctx.environ)
        env.setdefault("PYTHONHASHSEED", "0")
        if self._ninja_joins_jobserver(ctx):
            env["MAKEFLAGS"] = f"-j --jobserver-auth=fifo:{ctx.jobserver_fifo}"
        return env

    def _ninja_joins_jobserver(self, ctx: PackageContext) -> bool:
        if self.generator(ctx) != NINJA or ctx.jobserver_fifo is None:
            return False
        ninja = self.ninja(ctx)
        return ninja is not None and ninja.jobserver

    def parallel_args(self, ctx: PackageContext) -> list[str]:
        """A Ninja that cannot join the jobserver gets a fixed share of the CPU budget."""
        if self.generator(ctx) != NINJA or self._ninja_joins_jobserver(ctx):
            return []
        return ["--parallel", str(max(1, ctx.options.jobs))]

    def external_inputs(self, ctx: PackageContext) -> ReadOutside:
        """What CMake's regeneration list, the build rules, the depfiles, the compiler's
        dependency lists, the verified globs and the install script name outside the package,
        and the programs the build ran (build_types/cmake_inputs.py)."""
        from wsbuild.build_types.cmake_inputs import external_inputs

        ninja = self.ninja(ctx)
        return external_inputs(ctx.build_dir, ctx.source_dir, ninja.path if ninja else None)

    def needs_configure(self, ctx: PackageContext) -> bool:
        own = cmake_options(ctx)
        if own.clean_cache or own.force_configure:
            return True
        state = self.state(ctx)
        return not state.cache or self._record(ctx) != state.record

    def _record(self, ctx: PackageContext) -> dict[str, Any]:
        """What decides whether to configure again: the source, the arguments, the compilers'
        variables (a change configures from scratch) and every other variable a
        CMakeLists.txt may read with $ENV{} (a change configures again: CMake does not
        notice one by itself)."""
        from wsbuild.record.environment import environment_digests

        return {"source": str(ctx.source_dir), "args": self.configure_args(ctx),
                "environment": _compiler_digests(ctx.environ),
                "variables": environment_digests(ctx.environ, not_inputs=_RUN_ONLY_ENVIRONMENT)}

    def prepare_configure_steps(self, ctx: PackageContext) -> list[Step]:
        """What goes before a configure: a cache CMake cannot configure again (made with
        another generator, with other compilers, or --cmake-clean-cache), a build directory
        built for the other install mode, and always the last configure's record (a configure
        that fails is tried again next time: the record of the last one goes first)."""
        steps = []
        state = self.state(ctx)
        build_dir = ctx.build_dir
        why = self._from_scratch(ctx, state)
        if state.cache and why:
            description, warning = why
            steps.append(Step(
                "clean cache", functools.partial(_remove_cache, warning=warning),
                description=f"remove the cache {description}",
                by_hand=Command(("rm", "-rf", "--", "CMakeCache.txt", "CMakeFiles"), build_dir),
                writes=(build_dir / "CMakeCache.txt", build_dir / "CMakeFiles")))
        switched = self.install_mode_switched(ctx)
        if switched:
            steps.append(Step(
                "empty build directory", functools.partial(_empty, why=switched),
                description=f"empty the build directory (but wsbuild's records): it was built "
                            f"{switched}", writes=(build_dir,)))
        record = build_dir / CONFIGURE_RECORD
        if state.record is not None:
            steps.append(Step(
                "forget configure", _forget_configure_record,
                description="drop the last configure's record (a failed configure is tried "
                            "again)",
                by_hand=Command(("rm", "-f", "--", str(record)), build_dir), writes=(record,)))
        return steps

    def _from_scratch(self, ctx: PackageContext, state: CMakeState) -> tuple[str, str] | None:
        """Why the cache must go before the configure, for the dry run and as the warning the
        build shows (None when it need not)."""
        if cmake_options(ctx).clean_cache:
            return "(--cmake-clean-cache)", ""
        wanted = self.generator(ctx)
        if state.generator is not None and state.generator != wanted:
            return (f"of another generator ({state.generator})",
                    f"{ctx.build_dir} was configured with the '{state.generator}' generator, "
                    f"this build uses '{wanted}': configuring it from scratch")
        before = state.record.get("environment") if state.record is not None else None
        if isinstance(before, dict):
            changed = [name for name, digest in _compiler_digests(ctx.environ).items()
                       if before.get(name) != digest]
            if changed:
                return (f"of other compilers ({', '.join(changed)} changed)",
                        f"{', '.join(changed)} changed since {ctx.build_dir} was configured: "
                        "configuring it from scratch (CMake reads them at the first configure)")
        return None

    def configure_step(self, ctx: PackageContext) -> Step:
        """`cmake SOURCE ARGS` in the build directory."""
        env, run_env = self._build_env(ctx)
        return Step("configure", command=Command(
            ("cmake", str(ctx.source_dir), *self.configure_args(ctx)), ctx.build_dir, env=env,
            run_env=run_env, problems=configure_problems),
            reads=(ctx.source_dir,), writes=(ctx.build_dir,))

    def configure_record_step(self, ctx: PackageContext) -> Step:
        """After a configure: the record of what it used, which decides the next one."""
        record = ctx.build_dir / CONFIGURE_RECORD
        return Step("configure record",
                    functools.partial(_write_configure_record, record=self._record(ctx)),
                    description="write what this configure used (its arguments, digests of "
                                "the environment)", writes=(record,))

    def install_mode_switched(self, ctx: PackageContext) -> str:
        """How the build directory was built, when it was for another install mode, whose
        leftovers break this build ("" when not): plain CMake has only one."""
        return ""

    def build_step(self, ctx: PackageContext) -> Step:
        command = ["cmake", "--build", str(ctx.build_dir), *self.parallel_args(ctx)]
        own = cmake_options(ctx)
        if own.target:
            command += ["--target", own.target]
        if own.clean_first:
            command.append("--clean-first")
        env, run_env = self._build_env(ctx)
        return Step("build", command=Command(tuple(command), ctx.build_dir, env=env,
                                             run_env=run_env),
                    reads=(ctx.source_dir, ctx.build_dir), writes=(ctx.build_dir,))

    def _build_env(self, ctx: PackageContext) -> tuple[dict[str, str], dict[str, str]]:
        """What configure and build set on top of the package environment (kept in reproduce
        lines), and what only this run has (Ninja's jobserver FIFO)."""
        full = self.build_environ(ctx)
        changed = {k: v for k, v in full.items() if ctx.environ.get(k) != v}
        run_env = {k: changed.pop(k) for k in ("MAKEFLAGS",) if k in changed}
        return changed, run_env

    def installs_in_place(self, ctx: PackageContext) -> bool:
        """Whether `cmake --install` ignores DESTDIR (ament's symlink install); plain CMake
        has no symlink install and always stages."""
        return False

    def install_steps(self, ctx: PackageContext) -> list[Step]:
        """`cmake --install`: into the prefix CMake was configured with. Isolated, the previous
        install is parked first and the new one moved into the stage after it (a failure puts
        the previous one back); merged, it stages through DESTDIR (this run's only: pasted by
        hand, it installs in place), or (a symlink install, which ignores DESTDIR) keeps the
        manifests' list of what it wrote."""
        command = ("cmake", "--install", str(ctx.build_dir))
        prefix = ctx.install_prefix
        install = Step("install", command=Command(command, ctx.build_dir),
                       reads=(ctx.build_dir,), writes=(prefix,))
        if ctx.options.merge_install and not self.installs_in_place(ctx):
            # the shared prefix cannot be swapped: stage through DESTDIR instead
            destdir = ctx.build_dir / ".wsbuild" / "destdir"
            return [
                Step("clear destdir", functools.partial(_remove_tree, path=destdir),
                     description="remove what an earlier install left in DESTDIR",
                     writes=(destdir,)),
                Step("install", command=Command(command, ctx.build_dir,
                                                run_env={"DESTDIR": str(destdir)}),
                     reads=(ctx.build_dir,), writes=(destdir,)),
                Step("stage", functools.partial(_take_destdir, destdir=destdir),
                     description="move what the install put into DESTDIR into the stage",
                     reads=(destdir,))]
        if ctx.options.merge_install:
            # symlink install into a merged prefix writes in place, as with colcon; the
            # manifests say what it wrote, so the merged record keeps (and later prunes) it
            return [install, Step("keep manifest", _keep_installed_in_place,
                                  description="keep the install manifests' list of files",
                                  reads=(ctx.build_dir,))]
        return [
            Step("park install", park_install,
                 description="park the previous install aside (a failure puts it back)",
                 writes=(prefix,)),
            install,
            Step("stage", stage_direct_install,
                 description="move the new install into the stage, put the previous one back",
                 reads=(prefix,), writes=(prefix,))]


#: what stays when a build directory is emptied: wsbuild's own records and markers
_KEPT_IN_BUILD_DIRECTORY = frozenset({".wsbuild", "COLCON_IGNORE", "AMENT_IGNORE"})


def empty_build_directory(build_dir: Path) -> None:
    """Remove what CMake and the build wrote into `build_dir` (a configure from scratch)."""
    for entry in os.scandir(build_dir):
        if entry.name in _KEPT_IN_BUILD_DIRECTORY:
            continue
        if entry.is_dir(follow_symlinks=False):
            shutil.rmtree(entry.path)
        else:
            os.unlink(entry.path)


def _remove_cache(ctx: PackageContext, *, warning: str) -> None:
    if warning:
        ctx.warn(warning)
    (ctx.build_dir / "CMakeCache.txt").unlink(missing_ok=True)
    shutil.rmtree(ctx.build_dir / "CMakeFiles", ignore_errors=True)


def _empty(ctx: PackageContext, *, why: str) -> None:
    # information: the option was switched on purpose, and its build directory follows
    ctx.note(f"built {why}: building it from scratch")
    empty_build_directory(ctx.build_dir)


def _forget_configure_record(ctx: PackageContext) -> None:
    (ctx.build_dir / CONFIGURE_RECORD).unlink(missing_ok=True)


def _write_configure_record(ctx: PackageContext, *, record: Mapping[str, object]) -> None:
    from wsbuild.files import atomic_write, private_directory

    path = ctx.build_dir / CONFIGURE_RECORD
    private_directory(path.parent)
    atomic_write(path, json.dumps(record, indent=1) + "\n", mode=0o600)


def _remove_tree(ctx: PackageContext, *, path: Path) -> None:
    if path.exists():
        shutil.rmtree(path)


def _take_destdir(ctx: PackageContext, *, destdir: Path) -> None:
    staged = destdir / str(ctx.install_prefix).lstrip(os.sep)
    if staged.exists():
        shutil.rmtree(ctx.stage_prefix)
        os.rename(staged, ctx.stage_prefix)
    shutil.rmtree(destdir, ignore_errors=True)


def _keep_installed_in_place(ctx: PackageContext) -> None:
    ctx.outputs.installed_in_place = tuple(_manifest_files(ctx))


def park_install(ctx: PackageContext) -> None:
    """Before an install that writes straight into the final prefix: the previous install
    aside, a fresh prefix (prefix/stage.py)."""
    from wsbuild.prefix.stage import park_previous_install

    park_previous_install(ctx.install_prefix, ctx.stage_prefix)


def stage_direct_install(ctx: PackageContext) -> None:
    """After it: the new install into the stage, the previous one back."""
    from wsbuild.prefix.stage import stage_direct_install as stage

    stage(ctx.install_prefix, ctx.stage_prefix)


def configure_problems(lines: list[str]) -> list[str]:
    """The warning and error blocks of a CMake configure's stderr. Plain `message()` output
    also goes to stderr but is not a problem, so it stays in the log only."""
    kept: list[str] = []
    in_block = False
    for line in lines:
        if line.startswith(("CMake Warning", "CMake Deprecation Warning", "CMake Error")):
            in_block = True
        elif in_block and not line.strip() and kept and not kept[-1].strip():
            in_block = False  # blocks end with an empty line after their indented body
        if in_block:
            kept.append(line)
    return kept


BUILD_TYPE = CMakeBuildType()
