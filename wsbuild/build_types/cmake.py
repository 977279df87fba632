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
distributed compiles (builder/resources/distcc.py) the launcher is ccache calling distcc, or distcc;
links and code generators then go through the local gate, whose CMake file the environment
names (`WSBUILD_LOCAL_GATE_CMAKE`, given to CMake as `CMAKE_PROJECT_INCLUDE`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

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
    CMakeFacts,
    CMakeState,
    NinjaTool,
    find_ninja,
    read_cmake_state,
    user_generator,
)
from wsbuild.build_types.cmake_actions import (
    empty, forget_cache, forget_configure_record, remove_cache)
from wsbuild.build_types.staging import staged_install_steps
from wsbuild.build_types.cmake_options import CMAKE_OPTIONS, CMakeOptions
from wsbuild.prefix.hooks import EnvironmentHooks
from wsbuild.record.configured import (CONFIGURED_FILE, Configured, reconfigure_reason,
                                       write_configured)
from wsbuild.record.dirty import Reason
from wsbuild.record.environment import UNSET, variable_digests


NINJA = "Ninja"
#: CMake's default generator on this platform, when nobody chooses one
DEFAULT_GENERATOR = "Unix Makefiles"
LAUNCHED_LANGUAGES = ("C", "CXX")
#: the local gate's CMake file of a distributed build (builder/resources/distcc.py)
LOCAL_GATE_VAR = "WSBUILD_LOCAL_GATE_CMAKE"
#: what CMake's Ninja generator runs every time, the same from the same (see
#: `CMakeBuildType.deterministic_targets`)
CMAKE_OWN_TARGETS = ("*CMakeFiles/VerifyGlobs.cmake_force", "*CMakeFiles/cmake.verify_globs")
#: what a C/C++ toolchain reads from the environment at the first configure only: a change
#: configures from scratch
COMPILER_ENVIRONMENT = ("CC", "CXX", "CFLAGS", "CXXFLAGS", "CPPFLAGS", "LDFLAGS")


def _compiler_digests(environ: Mapping[str, str]) -> dict[str, str | None]:
    """Each compiler variable by a digest of its value (None: unset)."""
    digests = variable_digests(environ, COMPILER_ENVIRONMENT)
    return {name: None if digests[name] == UNSET else digests[name]
            for name in COMPILER_ENVIRONMENT}


def _redone(ctx: PackageContext) -> set[str]:
    """The steps whose last run read what changed, where CMake does not watch it."""
    return set(ctx.redo)


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
    """The `cmake` build type: configure, build and install with CMake, tests with CTest."""

    name: str = "cmake"
    #: colcon-ros gives a plain CMake package with a package.xml its pkg-config paths
    hooks: EnvironmentHooks = EnvironmentHooks(cmake_prefix_path=True, pkg_config_path=True)
    estimate_base: float = 1.5
    test_runner = RunnerNamed("wsbuild.build_types.ctest:CTEST")

    #: --cmake-args, --cmake-target, … (cmake_options.py)
    options: tuple[TypeOption, ...] = CMAKE_OPTIONS
    #: plain CMake reads package.xml with nothing stricter than wsbuild
    manifest_reader: str = ""

    def open_run(self, environ: Mapping[str, str]) -> None:
        """Nothing to open: Ninja is found once per run by `run_facts`."""

    def close_run(self) -> None:
        """Nothing to stop: every step is a process of its own."""

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
        clean = self.clean_step(ctx)
        if clean is not None:
            steps.append(clean)
        why = self.configure_reason(ctx)
        if why is not None:
            steps += self.prepare_configure_steps(ctx)
            steps.append(self.configure_step(ctx, why))
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
        if not _defines(cmake_options(ctx).args, "CMAKE_FIND_USE_PACKAGE_REGISTRY"):
            # the user package registry (~/.cmake/packages) is found through HOME: a configure
            # that looks there reads HOME, and its build is then not shared with another
            # user's; export(PACKAGE) fills it only where a project turns it on (CMP0090)
            args.append("-DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF")
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
        configured = self.state(ctx).configured
        previous = configured.args if configured is not None else ()
        return any(a == "-UCMAKE_PROJECT_INCLUDE" or (
            a.startswith("-DCMAKE_PROJECT_INCLUDE=") and a.endswith("local_gate.cmake"))
            for a in previous)

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

    def outside_reads(self, ctx: PackageContext) -> ReadOutside:
        """What CMake's regeneration list, the build rules, the depfiles, the compiler's
        dependency lists, the verified globs and the install script name outside the package,
        and the programs the build ran (build_types/cmake_reads.py)."""
        from wsbuild.build_types.cmake_reads import outside_reads  # lazy: off the full no-op build

        ninja = self.ninja(ctx)
        return outside_reads(ctx.build_dir, ctx.source_dir, ninja.path if ninja else None)

    def configure_reason(self, ctx: PackageContext) -> Reason | None:
        """Why CMake configures before the build (None: it need not), asked of record/ as a
        package's build is: when asked, when there is no cache, when the source, the arguments
        or the compilers' variables differ from the last configure's, and when the last
        configure read a file or a variable that changed since (`ctx.redo`: the package's
        record says which step read what changed; CMake itself watches only its own list of
        files, not what `file(READ)` or `$ENV{}` read). What the build step read counts too: a
        build step runs CMake's configure again when a file CMake watches changed, and what
        that configure read is the build step's. A clean goes before a configure
        (`clean_step`)."""
        own = cmake_options(ctx)
        asked = next((flag for flag, on in (("--cmake-clean-cache", own.clean_cache),
                                            ("--cmake-force-configure", own.force_configure),
                                            ("--cmake-clean-first", own.clean_first)) if on), "")
        state = self.state(ctx)
        return reconfigure_reason(state.configured, self.configured(ctx),
                                  configured=state.cache, asked=asked, redo=_redone(ctx))

    def configured(self, ctx: PackageContext) -> Configured:
        """What a configure now uses, as the last one's is kept: the source, the arguments
        and the compilers' variables (a change of those configures from scratch)."""
        return Configured(str(ctx.source_dir), tuple(self.configure_args(ctx)),
                          _compiler_digests(ctx.environ))

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
            description, _ = why
            steps.append(Step(
                "clean cache", self.clean_cache,
                description=f"remove the cache {description}",
                by_hand=Command(("rm", "-rf", "--", "CMakeCache.txt", "CMakeFiles"), build_dir),
                writes=(build_dir / "CMakeCache.txt", build_dir / "CMakeFiles")))
        elif state.cache and {"configure", "build"} & _redone(ctx):
            steps.append(Step(
                "forget cache", forget_cache,
                description="remove CMakeCache.txt: the last configure read what changed, and "
                            "CMake keeps what find_* and check_* found there (they look again; "
                            "the objects stay)",
                by_hand=Command(("rm", "-f", "--", "CMakeCache.txt"), build_dir),
                writes=(build_dir / "CMakeCache.txt",)))
        switched = self.install_mode_switched(ctx)
        if switched:
            steps.append(Step(
                "empty build directory", self.empty_for_install_mode,
                description=f"empty the build directory (but wsbuild's records): it was built "
                            f"{switched}", writes=(build_dir,)))
        record = build_dir / CONFIGURED_FILE
        if state.configured is not None:
            steps.append(Step(
                "forget configure", forget_configure_record,
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
        if state.configured is not None:
            before = state.configured.compilers
            changed = [name for name, digest in _compiler_digests(ctx.environ).items()
                       if before.get(name) != digest]
            if changed:
                return (f"of other compilers ({', '.join(changed)} changed)",
                        f"{', '.join(changed)} changed since {ctx.build_dir} was configured: "
                        "configuring it from scratch (CMake reads them at the first configure)")
        return None

    def configure_step(self, ctx: PackageContext, why: Reason | None = None) -> Step:
        """`cmake SOURCE ARGS` in the build directory (`why`: the reason it runs)."""
        env, run_env = self._build_env(ctx)
        return Step("configure", command=Command(
            ("cmake", str(ctx.source_dir), *self.configure_args(ctx)), ctx.build_dir, env=env,
            run_env=run_env, problems=configure_problems),
            reads=(ctx.source_dir,), writes=(ctx.build_dir,), why=why)

    def configure_record_step(self, ctx: PackageContext) -> Step:
        """After a configure: the record of what it used, which decides the next one."""
        record = ctx.build_dir / CONFIGURED_FILE
        return Step("configure record", self.record_configure,
                    description="write what this configure used (its arguments, digests of "
                                "the environment)", writes=(record,))

    # the steps that run in wsbuild: each decides what it does from the context it runs with
    # (the build's), not from values the plan bound

    def clean_cache(self, ctx: PackageContext) -> None:
        """Remove a cache CMake cannot configure again, warning why (when it was not asked)."""
        why = self._from_scratch(ctx, self.state(ctx))
        remove_cache(ctx, warning=why[1] if why is not None else "")

    def empty_for_install_mode(self, ctx: PackageContext) -> None:
        """Empty a build directory built for the other install mode."""
        empty(ctx, why=self.install_mode_switched(ctx))

    def record_configure(self, ctx: PackageContext) -> None:
        """What the configure that just ran used: its arguments, its compilers' digests."""
        write_configured(ctx.build_dir, self.configured(ctx))

    def install_mode_switched(self, ctx: PackageContext) -> str:
        """How the build directory was built, when it was for another install mode, whose
        leftovers break this build ("" when not): plain CMake has only one."""
        return ""

    def clean_step(self, ctx: PackageContext) -> Step | None:
        """The generator's `clean` target, before the configure, when everything is built
        again: asked for (--cmake-clean-first), or the last build read a variable or a file
        that changed and that the generator does not watch (a compiler's CPATH, a custom
        command's own input). Cleaning after the configure (`cmake --build --clean-first`)
        would delete what the configure wrote that a build rule names (rosidl's visibility
        headers), which no build writes again; so the configure runs after the clean."""
        if not (cmake_options(ctx).clean_first or "build" in _redone(ctx)):
            return None
        state = self.state(ctx)
        if not state.cache or self._from_scratch(ctx, state):
            return None  # nothing built yet, or the configure starts from scratch anyway
        env, run_env = self._build_env(ctx)
        return Step("clean", command=Command(
            ("cmake", "--build", str(ctx.build_dir), "--target", "clean"), ctx.build_dir,
            env=env, run_env=run_env), reads=(ctx.build_dir,), writes=(ctx.build_dir,))

    def build_step(self, ctx: PackageContext) -> Step:
        command = ["cmake", "--build", str(ctx.build_dir), *self.parallel_args(ctx)]
        own = cmake_options(ctx)
        if own.target:
            command += ["--target", own.target]
        env, run_env = self._build_env(ctx)
        return Step("build", command=Command(tuple(command), ctx.build_dir, env=env,
                                             run_env=run_env),
                    reads=(ctx.source_dir, ctx.build_dir), writes=(ctx.build_dir,))

    def work_left(self, ctx: PackageContext) -> str:
        """What the build system still runs right after the build (cmake_work_left.py)."""
        from wsbuild.build_types.cmake_work_left import work_left  # lazy: off the full no-op build

        ninja = self.ninja(ctx)
        return work_left(ctx.build_dir, self.generator(ctx), ninja.path if ninja else None,
                         cmake_options(ctx).target, ctx.environ, self.deterministic_targets)

    #: always-run targets (their outputs as `ninja -d explain` names them) that make the same
    #: files from what they read: CMake's check of `file(GLOB … CONFIGURE_DEPENDS)`
    deterministic_targets: tuple[str, ...] = CMAKE_OWN_TARGETS

    def keeps_earlier_work(self, ctx: PackageContext) -> bool:
        """Whether this build reuses what an earlier one left in the build directory (Ninja
        rebuilds only what changed, so what the earlier steps read still decides part of the
        output): there is a cache, and it is not removed before the configure."""
        state = self.state(ctx)
        return bool(state.cache) and not (state.cache and self._from_scratch(ctx, state)) \
            and not self.install_mode_switched(ctx)

    def steps_run_afresh(self, ctx: PackageContext) -> frozenset[str]:
        """The steps whose earlier reads no longer count after this build, even where it
        keeps earlier work: the install (it installs everything every time), the configure
        when it starts from a fresh cache, the build when it builds everything again."""
        afresh = {"install", "clean"}
        redone = _redone(ctx)
        if {"configure", "build"} & redone:
            afresh.add("configure")
        if "build" in redone or cmake_options(ctx).clean_first:
            afresh.add("build")
        return frozenset(afresh)

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
        """`cmake --install` into the prefix CMake was configured with, staged
        (build_types/staging.py): isolated, the previous install parked around it; merged,
        through DESTDIR (this run's only: pasted by hand, it installs in place), or (a
        symlink install, which ignores DESTDIR) with the manifests' list of what it wrote."""
        install = Command(("cmake", "--install", str(ctx.build_dir)), ctx.build_dir)
        return staged_install_steps(ctx, install, reads=(ctx.build_dir,),
                                    in_place=_manifest_files if self.installs_in_place(ctx)
                                    else None)

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
