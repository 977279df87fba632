"""The environment and CMake arguments a build needs on a wheel-venv ROS underlay.

The wheels' shared libraries live in `<venv>/lib` and in `site-packages/ros_*.libs`
(auditwheel copies of libssl, tinyxml2, spdlog, yaml, lttng-ust ...).  Their RPATHs point
outside the venv, so nothing loads without `LD_LIBRARY_PATH`.  The
`ros_wheels_bootstrapper.pth` file therefore makes every Python started in the venv
re-execute itself once with `LD_LIBRARY_PATH` extended, unless `BOOTSTRAP_GUARD_VAR` is set
in its environment; `build_environment` computes the same variables so that neither the
build nor the processes it starts pay for (or depend on) that re-exec.

The `lib*__rosidl_generator_py.so` libraries (exported by every message package and linked by
rcl) do not link libpython, so C/C++ executables need it on their link line
(`cmake_arguments`); the pybind11_vendor wheel relies on PyPI's `pybind11`, whose CMake
config lives in site-packages (`cmake_prefixes`).  `prepare_underlay` puts detection, repair,
environment and the lint stand-in together for one build.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import UnderlayError
from wsbuild.underlay.detect import (
    BOOTSTRAP_GUARD_VAR,
    find_venv_underlay,
    is_ament_prefix,
    ros_distro,
    site_packages_dirs,
    venv_python,
)
from wsbuild.underlay.lint import prepare_lint
from wsbuild.underlay.repair import repair_underlay, scan_underlay
from wsbuild import inputs

# ------------------------------------------------------------------- public: environment


def library_dirs(prefix: Path) -> list[Path]:
    """`LD_LIBRARY_PATH` entries the wheels need, at build (link) time and at run time.

    `<prefix>/lib`, every `site-packages/ros_*.libs` (sorted; the bootstrapper uses set
    order), and the base interpreter's libpython directory when it is not a system one
    (pyenv, uv): executables linking rcl or message targets need libpython, see
    `cmake_arguments`.
    """
    prefix = Path(os.path.abspath(prefix))
    dirs = [prefix / "lib"]
    for site in site_packages_dirs(prefix):
        dirs.extend(sorted(p for p in site.glob("ros_*.libs") if p.is_dir()))
    try:
        python = venv_python(prefix)
    except UnderlayError:
        python = None
    if python is not None and python.library is not None:
        libdir = python.library.parent
        if not str(libdir).startswith(("/usr/lib", "/lib")) and libdir not in dirs:
            dirs.append(libdir)
    return dirs


def executable_dirs(prefix: Path) -> list[Path]:
    """`PATH` entries of the underlay: `<prefix>/bin`, then the `opt/<vendor>/bin` directories
    of vendor packages (uncrustify_vendor: ament_uncrustify runs the `uncrustify` found on
    PATH), which a sourced ROS install adds through their environment hooks."""
    prefix = Path(os.path.abspath(prefix))
    return [prefix / "bin", *(Path(d) / "bin" for d in inputs.glob_dirs(prefix / "opt", "*")
                              if inputs.is_dir(Path(d) / "bin"))]


def cmake_prefixes(prefix: Path) -> list[Path]:
    """`CMAKE_PREFIX_PATH` entries of the underlay: the venv, and the `pybind11` PyPI package's
    own prefix (the pybind11_vendor wheel depends on it instead of vendoring pybind11, and
    its `pybind11Config.cmake` lives in `site-packages/pybind11/share/cmake/pybind11`)."""
    prefix = Path(os.path.abspath(prefix))
    result = [prefix]
    for site in site_packages_dirs(prefix):
        if inputs.is_dir(site / "pybind11" / "share" / "cmake" / "pybind11"):
            result.append(site / "pybind11")
    return result


def _prepend(value: str | None, entries: Iterable[str]) -> str:
    current = [p for p in (value or "").split(os.pathsep) if p]
    new = [e for e in entries if e not in current]
    return os.pathsep.join(new + current)


def build_environment(prefix: Path, environ: Mapping[str, str]) -> dict[str, str]:
    """The variables to set (their complete new values) for builds and for ROS processes.

    Equivalent of sourcing the underlay's setup script: prepends the venv to `PATH`
    (`executable_dirs`),
    `AMENT_PREFIX_PATH` (rosidl finds its typesupports through the ament index:
    without it `No 'rosidl_typesupport_c' found`), `CMAKE_PREFIX_PATH` (`cmake_prefixes`) and
    `LD_LIBRARY_PATH` (`library_dirs`), sets `VIRTUAL_ENV`, the bootstrap guard (so
    child Pythons do not re-exec) and, when unset, `ROS_VERSION`, `ROS_PYTHON_VERSION`,
    `ROS_DISTRO`.  Entries already present are not repeated.  `RMW_IMPLEMENTATION` is
    left alone: only rmw_fastrtps_cpp ships as a wheel and it is the default.
    """
    prefix = Path(os.path.abspath(prefix))
    text = str(prefix)
    changes: dict[str, str] = {
        "VIRTUAL_ENV": text,
        "PATH": _prepend(environ.get("PATH"), [str(p) for p in executable_dirs(prefix)]),
        "AMENT_PREFIX_PATH": _prepend(environ.get("AMENT_PREFIX_PATH"), [text]),
        "CMAKE_PREFIX_PATH": _prepend(
            environ.get("CMAKE_PREFIX_PATH"), [str(p) for p in cmake_prefixes(prefix)]
        ),
        "LD_LIBRARY_PATH": _prepend(environ.get("LD_LIBRARY_PATH"), [str(d) for d in library_dirs(prefix)]),
        BOOTSTRAP_GUARD_VAR: "1",
    }
    defaults = {"ROS_VERSION": "2", "ROS_PYTHON_VERSION": "3", "ROS_DISTRO": ros_distro(prefix) or "jazzy"}
    for key, value in defaults.items():
        if not environ.get(key):
            changes[key] = value
    return {k: v for k, v in changes.items() if environ.get(k) != v}


def cmake_arguments(prefix: Path, *, link_libpython: bool = True) -> list[str]:
    """CMake `-D` arguments for ament_cmake packages built against the wheel underlay.

    * `Python3_EXECUTABLE`: the venv's python (ament_cmake, rosidl generators, install dir).
    * `CMAKE_EXE_LINKER_FLAGS`: link libpython into executables.  The wheels'
      `lib*__rosidl_generator_py.so` do not link libpython (manylinux rules) but rcl and
      every message package export them, so a C/C++ executable linking rcl or
      `${msgs_TARGETS}` fails with `undefined reference to _Py_Dealloc` otherwise.  Only
      executables get it (never Python extension modules).  Callers that pass their own
      `CMAKE_EXE_LINKER_FLAGS` must append theirs to this value.
    """
    python = venv_python(Path(os.path.abspath(prefix)))
    args = [f"-DPython3_EXECUTABLE={python.executable}"]
    if link_libpython and python.library is not None:
        args.append(
            f"-DCMAKE_EXE_LINKER_FLAGS=-Wl,--push-state,--no-as-needed {python.library} -Wl,--pop-state"
        )
    return args


# ------------------------------------------------------------------ the build's view


@dataclass(frozen=True)
class PreparedUnderlay:
    """What a build needs to know about the underlay it builds against."""

    environ: dict[str, str]
    #: the virtualenv underlay (None when the ROS underlay came from a sourced setup script)
    venv: Path | None
    #: extra CMake arguments (Python3_EXECUTABLE, libpython link flags) for the wheel underlay
    cmake_args: tuple[str, ...]
    #: variables `install/setup.*` must set for the venv underlay (complete values at build time)
    venv_changes: tuple[tuple[str, str], ...] = ()
    #: CMake packages of ament linters (and ament_lint_auto/common) replaced by stand-ins
    lint_stand_ins: tuple[str, ...] = ()
    #: linter CMake packages wsbuild writes for a program installed without its CMake package
    lint_driven: tuple[str, ...] = ()


def prepare_underlay(
    environ: Mapping[str, str],
    *,
    executable: str,
    repair: bool,
    shim_dir: Path,
    notice: Callable[[str], None],
    dry_run: bool = False,
) -> PreparedUnderlay:
    """Detect the ROS underlay, repair a wheel venv if needed, and compute the build environment.

    Also makes the ament linters that are not installed (ament_lint_auto, ament_lint_common and
    the linters without a wheel) stand-ins that register no test (underlay/lint.py).
    `dry_run` computes the same without repairing or writing anything (`build --dry-run`).
    """
    env = dict(environ)
    venv = find_venv_underlay(environ, executable)
    cmake_args: tuple[str, ...] = ()
    changes: dict[str, str] = {}
    if venv is not None:
        problems = scan_underlay(venv)
        fatal = [p for p in problems if not p.repairable]
        if fatal:
            raise UnderlayError(fatal[0].text, path=fatal[0].path, hint=fatal[0].fix)
        if problems and dry_run:
            notice(f"the build would first repair {len(problems)} broken line(s) of the ROS "
                   f"underlay in {venv}")
        elif problems:
            if not repair:
                raise UnderlayError(
                    f"the ROS underlay has {len(problems)} broken line(s) from the wheels' "
                    "build machine",
                    path=problems[0].path, line=problems[0].line,
                    hint="run: wsbuild underlay repair",
                )
            changed = repair_underlay(venv)
            notice(f"repaired {len(changed)} file(s) of the ROS underlay in {venv} "
                   "(paths of the wheels' build machine); see 'wsbuild underlay check'")
        changes = build_environment(venv, env)
        env.update(changes)
        cmake_args = tuple(cmake_arguments(venv))
    prefixes = [Path(p) for p in env.get("CMAKE_PREFIX_PATH", "").split(os.pathsep) if p]
    prefixes += [Path(p) for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    has_ament = any(is_ament_prefix(p) for p in prefixes)
    stand_ins: tuple[str, ...] = ()
    driven: tuple[str, ...] = ()
    if has_ament:
        lint = prepare_lint(prefixes, env.get("PATH", ""), shim_dir, write=not dry_run)
        cmake_args += lint.cmake_args
        stand_ins, driven = lint.stand_ins, lint.driven
    return PreparedUnderlay(environ=env, venv=venv, cmake_args=cmake_args,
                            venv_changes=tuple(sorted(changes.items())),
                            lint_stand_ins=stand_ins, lint_driven=driven)
