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

import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from wsbuild.build_types import (
    BuildContext,
    BuildOptions,
    Command,
    ReadOutside,
    RunnerNamed,
    Step,
    cmake_key_options,
)
from wsbuild.prefix.hooks import EnvironmentHooks
from wsbuild.prefix.stage import direct_install


#: what the last configure used, to know when to configure again
CONFIGURE_RECORD = Path(".wsbuild") / "cmake_configure.json"
NINJA = "Ninja"
#: CMake's default generator on this platform, when nobody chooses one
DEFAULT_GENERATOR = "Unix Makefiles"
#: the first Ninja release that is a GNU make jobserver client
NINJA_JOBSERVER = (1, 13)
LAUNCHED_LANGUAGES = ("C", "CXX")
#: the local gate's CMake file of a distributed build (builder/distribute.py)
LOCAL_GATE_VAR = "WSBUILD_LOCAL_GATE_CMAKE"
#: what a C/C++ toolchain reads from the environment at the first configure only: a change
#: configures from scratch
COMPILER_ENVIRONMENT = ("CC", "CXX", "CFLAGS", "CXXFLAGS", "CPPFLAGS", "LDFLAGS")
#: what wsbuild sets in a build's environment for one run only (the jobserver, the compiler
#: cache's and distcc's private files): not what a configure depends on
_RUN_ONLY_ENVIRONMENT = ("MAKEFLAGS", "CCACHE_*", "SCCACHE_*", "DISTCC_*")


@dataclass(frozen=True, slots=True)
class NinjaTool:
    path: Path
    version: tuple[int, ...]

    @property
    def jobserver(self) -> bool:
        return self.version >= NINJA_JOBSERVER


_ninja_found: dict[tuple[str, ...], NinjaTool | None] = {}


def _ninja_version(path: Path) -> tuple[int, ...] | None:
    try:
        done = subprocess.run([str(path), "--version"], capture_output=True, text=True,
                              timeout=30, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    match = re.match(r"(\d+(?:\.\d+)*)", done.stdout.strip())
    if done.returncode != 0 or not match:
        return None
    return tuple(int(part) for part in match.group(1).split("."))


def find_ninja(environ: Mapping[str, str]) -> NinjaTool | None:
    """The `ninja` to build with: the first jobserver client (≥ 1.13) among those on PATH and
    next to wsbuild's interpreter, else the first one found; None when there is none."""
    candidates: list[Path] = []
    for directory in [*environ.get("PATH", "").split(os.pathsep), str(Path(sys.executable).parent)]:
        if directory:
            path = Path(directory) / "ninja"
            if path not in candidates and path.is_file() and os.access(path, os.X_OK):
                candidates.append(path)
    key = tuple(str(c) for c in candidates)
    if key not in _ninja_found:
        tools = [NinjaTool(c, v) for c in candidates if (v := _ninja_version(c)) is not None]
        _ninja_found[key] = next((t for t in tools if t.jobserver), tools[0] if tools else None)
    return _ninja_found[key]


def user_generator(cmake_args: Sequence[str], environ: Mapping[str, str]) -> str | None:
    """The generator the user chose: `-G X` / `-GX` in --cmake-args (the last wins), else
    CMake's own `CMAKE_GENERATOR` variable."""
    chosen = None
    for index, arg in enumerate(cmake_args):
        if arg == "-G" and index + 1 < len(cmake_args):
            chosen = cmake_args[index + 1]
        elif arg.startswith("-G") and len(arg) > 2:
            chosen = arg[2:]
    return chosen or environ.get("CMAKE_GENERATOR") or None


def cached_generator(build_dir: Path) -> str | None:
    """The generator a build directory was configured with (from its CMakeCache.txt)."""
    try:
        text = (build_dir / "CMakeCache.txt").read_text(errors="replace")
    except OSError:
        return None
    match = re.search(r"^CMAKE_GENERATOR:INTERNAL=(.*)$", text, re.MULTILINE)
    return match.group(1).strip() if match else None


def _compiler_digests(environ: Mapping[str, str]) -> dict[str, str | None]:
    """Each compiler variable by a digest of its value (None: unset)."""
    from wsbuild.record.environment import environment_digests

    digests = environment_digests({k: environ[k] for k in COMPILER_ENVIRONMENT if k in environ})
    return {name: digests.get(name) for name in COMPILER_ENVIRONMENT}


def _defines(cmake_args: Sequence[str], name: str) -> bool:
    return any(a.startswith((f"-D{name}=", f"-D{name}:")) for a in cmake_args)


def _manifest_files(ctx: BuildContext) -> list[str]:
    files: list[str] = []
    for name in ("install_manifest.txt", "symlink_install_manifest.txt"):
        path = ctx.build_dir / name
        if path.is_file():
            for line in path.read_text().splitlines():
                if line.strip() and Path(line).is_relative_to(ctx.install_prefix):
                    files.append(str(Path(line).relative_to(ctx.install_prefix)))
    return sorted(set(files))


@dataclass(frozen=True, slots=True)
class CMakeBuildType:
    name: str = "cmake"
    #: colcon-ros gives a plain CMake package with a package.xml its pkg-config paths
    hooks: EnvironmentHooks = EnvironmentHooks(cmake_prefix_path=True, pkg_config_path=True)
    estimate_base: float = 1.5
    test_runner = RunnerNamed("wsbuild.build_types.ctest:CTEST")

    def key_options(self, options: BuildOptions) -> dict[str, object]:
        # --ament-cmake-args reach ament_cmake packages only (AmentCMakeBuildType)
        return {k: v for k, v in cmake_key_options(options).items() if k != "ament_cmake_args"}

    def steps(self, ctx: BuildContext) -> list[Step]:
        steps = []
        if self.needs_configure(ctx):
            steps.append(self.configure_step(ctx))
        steps.append(self.build_step(ctx))
        steps.append(self.install_step(ctx))
        return steps

    def configure_args(self, ctx: BuildContext) -> list[str]:
        python = ctx.options.python_executable
        args = [
            # wsbuild passes Python hints every project may ignore: don't warn about them
            "--no-warn-unused-cli",
            *self.generator_args(ctx),
            f"-DCMAKE_INSTALL_PREFIX={ctx.install_prefix}",
            "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON",
            f"-DPYTHON_EXECUTABLE={python}",
        ]
        if not any(a.startswith("-DPython3_EXECUTABLE=") for a in ctx.options.underlay_cmake_args):
            args.append(f"-DPython3_EXECUTABLE={python}")
        args += self.launcher_args(ctx)
        return [*args, *ctx.options.underlay_cmake_args, *ctx.options.cmake_args]

    def generator(self, ctx: BuildContext) -> str:
        """The generator this configure uses (the user's, else Ninja when found, else CMake's
        default)."""
        chosen = user_generator(ctx.options.cmake_args, ctx.environ)
        if chosen:
            return chosen
        return NINJA if find_ninja(ctx.environ) is not None else DEFAULT_GENERATOR

    def generator_args(self, ctx: BuildContext) -> list[str]:
        args = []
        user = user_generator(ctx.options.cmake_args, ctx.environ)
        ninja = find_ninja(ctx.environ)
        if user is None and ninja is not None:
            args += ["-G", NINJA]
        if ninja is not None and (user or NINJA) == NINJA \
                and not _defines(ctx.options.cmake_args, "CMAKE_MAKE_PROGRAM"):
            # the ninja whose version decided how it shares the CPU budget
            args.append(f"-DCMAKE_MAKE_PROGRAM={ninja.path}")
        return args

    def launcher_args(self, ctx: BuildContext) -> list[str]:
        """The compiler cache as C/C++ compiler launcher; without one, a launcher an earlier
        configure left in the cache is removed (the user's own --cmake-args always win)."""
        args = []
        for language in LAUNCHED_LANGUAGES:
            name = f"CMAKE_{language}_COMPILER_LAUNCHER"
            if _defines(ctx.options.cmake_args, name):
                continue
            if ctx.options.compiler_launcher:
                args.append(f"-D{name}={ctx.options.compiler_launcher}")
            else:
                args.append(f"-U{name}")
        gate = ctx.environ.get(LOCAL_GATE_VAR, "")
        if gate and not _defines(ctx.options.cmake_args, "CMAKE_PROJECT_INCLUDE"):
            args.append(f"-DCMAKE_PROJECT_INCLUDE={gate}")
        elif not gate and self._gate_configured(ctx):
            # a distributed build's gate goes away; kept in later records, so that a local
            # build after a distributed one configures once, not every time
            args.append("-UCMAKE_PROJECT_INCLUDE")
        return args

    def _gate_configured(self, ctx: BuildContext) -> bool:
        record = self._read_record(ctx)
        previous = record.get("args", []) if isinstance(record, dict) else []
        return any(a == "-UCMAKE_PROJECT_INCLUDE" or (
            a.startswith("-DCMAKE_PROJECT_INCLUDE=") and a.endswith("local_gate.cmake"))
            for a in previous if isinstance(a, str))

    def build_environ(self, ctx: BuildContext) -> dict[str, str]:
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

    def _ninja_joins_jobserver(self, ctx: BuildContext) -> bool:
        if self.generator(ctx) != NINJA or ctx.jobserver_fifo is None:
            return False
        ninja = find_ninja(ctx.environ)
        return ninja is not None and ninja.jobserver

    def parallel_args(self, ctx: BuildContext) -> list[str]:
        """A Ninja that cannot join the jobserver gets a fixed share of the CPU budget."""
        if self.generator(ctx) != NINJA or self._ninja_joins_jobserver(ctx):
            return []
        return ["--parallel", str(max(1, ctx.options.jobs))]

    def external_inputs(self, ctx: BuildContext) -> ReadOutside:
        """What CMake's regeneration list, the build rules, the depfiles, the compiler's
        dependency lists, the verified globs and the install script name outside the package,
        and the programs the build ran (build_types/cmake_inputs.py)."""
        from wsbuild.build_types.cmake_inputs import external_inputs

        ninja = find_ninja(ctx.environ)
        return external_inputs(ctx.build_dir, ctx.source_dir, ninja.path if ninja else None)

    def needs_configure(self, ctx: BuildContext) -> bool:
        cache = ctx.build_dir / "CMakeCache.txt"
        if ctx.options.cmake_clean_cache or ctx.options.cmake_force_configure:
            return True
        if not cache.exists():
            return True
        return self._record(ctx) != self._read_record(ctx)

    def _record(self, ctx: BuildContext) -> dict[str, Any]:
        """What decides whether to configure again: the source, the arguments, the compilers'
        variables (a change configures from scratch) and every other variable a
        CMakeLists.txt may read with $ENV{} (a change configures again: CMake does not
        notice one by itself)."""
        from wsbuild.record.environment import environment_digests

        return {"source": str(ctx.source_dir), "args": self.configure_args(ctx),
                "environment": _compiler_digests(ctx.environ),
                "variables": environment_digests(ctx.environ, not_inputs=_RUN_ONLY_ENVIRONMENT)}

    def _read_record(self, ctx: BuildContext) -> object:
        try:
            return json.loads((ctx.build_dir / CONFIGURE_RECORD).read_text())
        except (OSError, ValueError):
            return None

    def configure_step(self, ctx: BuildContext) -> Step:
        """`cmake SOURCE ARGS` in the build directory; before it, a cache of another generator
        (or --cmake-clean-cache) goes and the configure record is dropped (a failed configure
        is retried next time); after it, the record of these arguments is written."""
        # the arguments (and the record) are decided before the old record goes
        now = self._record(ctx)
        args = now["args"]
        env, run_env = self._build_env(ctx)
        return Step("configure", command=Command(
            ("cmake", str(ctx.source_dir), *args), ctx.build_dir, env=env, run_env=run_env,
            problems=configure_problems),
            description="drop a cache of another generator and the configure record first; "
            "write the record after",
            before=self._prepare_configure,
            after=lambda context: _write_configure_record(context, now),
            reads=(ctx.source_dir,), writes=(ctx.build_dir,))

    def _prepare_configure(self, ctx: BuildContext) -> None:
        cache = ctx.build_dir / "CMakeCache.txt"
        previous = cached_generator(ctx.build_dir)
        wanted = self.generator(ctx)
        if previous is not None and previous != wanted and not ctx.options.cmake_clean_cache:
            ctx.warn(f"{ctx.build_dir} was configured with the '{previous}' generator, this "
                     f"build uses '{wanted}': configuring it from scratch")
        before = self._read_record(ctx)
        toolchain = _compiler_digests(ctx.environ)
        changed = [name for name, digest in toolchain.items() if isinstance(before, dict)
                   and isinstance(before.get("environment"), dict)
                   and before["environment"].get(name) != digest]
        if cache.exists() and changed:
            ctx.warn(f"{', '.join(changed)} changed since {ctx.build_dir} was configured: "
                     "configuring it from scratch (CMake reads them at the first configure)")
        if cache.exists() and (ctx.options.cmake_clean_cache or changed
                               or (previous is not None and previous != wanted)):
            cache.unlink()
            shutil.rmtree(ctx.build_dir / "CMakeFiles", ignore_errors=True)
        (ctx.build_dir / CONFIGURE_RECORD).unlink(missing_ok=True)
        switched = self.install_mode_switched(ctx)
        if switched:
            ctx.warn(f"{ctx.build_dir} was built {switched}: building it from scratch")
            empty_build_directory(ctx.build_dir)

    def install_mode_switched(self, ctx: BuildContext) -> str:
        """How the build directory was built, when it was for another install mode, whose
        leftovers break this build ("" when not): plain CMake has only one."""
        return ""

    def build_step(self, ctx: BuildContext) -> Step:
        command = ["cmake", "--build", str(ctx.build_dir), *self.parallel_args(ctx)]
        if ctx.options.cmake_target:
            command += ["--target", ctx.options.cmake_target]
        if ctx.options.cmake_clean_first:
            command.append("--clean-first")
        env, run_env = self._build_env(ctx)
        return Step("build", command=Command(tuple(command), ctx.build_dir, env=env,
                                             run_env=run_env),
                    reads=(ctx.source_dir, ctx.build_dir), writes=(ctx.build_dir,))

    def _build_env(self, ctx: BuildContext) -> tuple[dict[str, str], dict[str, str]]:
        """What configure and build set on top of the package environment (kept in reproduce
        lines), and what only this run has (Ninja's jobserver FIFO)."""
        full = self.build_environ(ctx)
        changed = {k: v for k, v in full.items() if ctx.environ.get(k) != v}
        run_env = {k: changed.pop(k) for k in ("MAKEFLAGS",) if k in changed}
        return changed, run_env

    def installs_in_place(self, ctx: BuildContext) -> bool:
        """Whether `cmake --install` ignores DESTDIR (ament's symlink install); plain CMake
        has no symlink install and always stages."""
        return False

    def install_step(self, ctx: BuildContext) -> Step:
        """`cmake --install`: into the prefix CMake was configured with. Isolated, wsbuild
        parks the previous install and moves the new one into the stage afterwards; merged,
        it stages through DESTDIR (this run's only: pasted by hand, it installs in place), or
        (a symlink install, which ignores DESTDIR) keeps the manifests' list of what it wrote.
        """
        command = ("cmake", "--install", str(ctx.build_dir))
        writes = (ctx.install_prefix,)
        if ctx.options.merge_install and not self.installs_in_place(ctx):
            # the shared prefix cannot be swapped: stage through DESTDIR instead
            destdir = ctx.build_dir / ".wsbuild" / "destdir"
            return Step("install", command=Command(command, ctx.build_dir,
                                                   run_env={"DESTDIR": str(destdir)}),
                        description="install through DESTDIR, then move it into the stage",
                        before=lambda context: _remove_tree(destdir),
                        after=lambda context: _take_destdir(context, destdir),
                        reads=(ctx.build_dir,), writes=writes)
        if ctx.options.merge_install:
            # symlink install into a merged prefix writes in place, as with colcon; the
            # manifests say what it wrote, so the merged record keeps (and later prunes) it
            return Step("install", command=Command(command, ctx.build_dir),
                        description="install in place; keep the manifests' list of files",
                        after=_keep_installed_in_place, reads=(ctx.build_dir,), writes=writes)
        return Step("install", command=Command(command, ctx.build_dir),
                    description="park the previous install; move the new one into the stage",
                    around=lambda context: direct_install(context.install_prefix,
                                                          context.stage_prefix),
                    reads=(ctx.build_dir,), writes=writes)


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


def _write_configure_record(ctx: BuildContext, record: Mapping[str, object]) -> None:
    path = ctx.build_dir / CONFIGURE_RECORD
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=1) + "\n")


def _remove_tree(path: Path) -> None:
    if path.exists():
        shutil.rmtree(path)


def _take_destdir(ctx: BuildContext, destdir: Path) -> None:
    staged = destdir / str(ctx.install_prefix).lstrip(os.sep)
    if staged.exists():
        shutil.rmtree(ctx.stage_prefix)
        os.rename(staged, ctx.stage_prefix)
    shutil.rmtree(destdir, ignore_errors=True)


def _keep_installed_in_place(ctx: BuildContext) -> None:
    ctx.outputs.installed_in_place = tuple(_manifest_files(ctx))


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
