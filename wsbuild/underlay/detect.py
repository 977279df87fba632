"""Detect the ROS underlay a virtualenv of PyPI wheels provides, and the facts about its Python.

`pip install ros-jazzy-rclpy ...` turns a virtualenv into a ROS underlay: the venv prefix
holds `share/ament_index/...`, `share/<pkg>/cmake/...`, `include/` and `lib/` like
`/opt/ros/jazzy` does.
"""

from __future__ import annotations

import fnmatch
import inspect
import json
import os
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import UnderlayError
from wsbuild import inputs

#: Set (to any non-empty value) in a child's environment, it stops
#: `ros_wheels_bootstrapper` from re-executing the interpreter.  Only set it together
#: with the `LD_LIBRARY_PATH` entries of `library_dirs`, or rclpy fails to import.
BOOTSTRAP_GUARD_VAR = "_ROS_WHEELS_BOOTSTRAP_COMPLETE"

RESOURCE_INDEX = Path("share", "ament_index", "resource_index")


@dataclass(frozen=True)
class VenvPython:
    """Facts about the venv's interpreter that a build needs (see `venv_python`)."""

    version: str
    executable: Path
    site_packages: Path
    include_dir: Path
    library: Path | None

    @property
    def has_headers(self) -> bool:
        """Whether `Python.h` is there (rosidl's Python extensions need it)."""
        return inputs.is_file(self.include_dir / "Python.h")

# ---------------------------------------------------------------------------- detection


def is_ament_prefix(prefix: Path) -> bool:
    return inputs.is_dir(prefix / RESOURCE_INDEX / "packages")


def find_venv_underlay(environ: Mapping[str, str], executable: str) -> Path | None:
    """The active virtualenv's prefix if it is a ROS underlay (holds an ament index).

    Candidates in order: `$VIRTUAL_ENV`; the venv that `executable` lives in
    (`<venv>/bin/python`, recognised by `<venv>/pyvenv.cfg`, symlinks not followed);
    `sys.prefix` of the running interpreter when it differs from `sys.base_prefix`.
    """
    candidates: list[Path] = []
    if environ.get("VIRTUAL_ENV"):
        candidates.append(Path(environ["VIRTUAL_ENV"]))
    if executable:
        venv = Path(os.path.abspath(executable)).parent.parent
        if inputs.is_file(venv / "pyvenv.cfg"):
            candidates.append(venv)
    if sys.prefix != sys.base_prefix:
        candidates.append(Path(sys.prefix))
    for candidate in candidates:
        if is_ament_prefix(candidate):
            return Path(os.path.abspath(candidate))
    return None


def site_packages_dirs(prefix: Path) -> list[Path]:
    return [Path(d) / "site-packages" for d in inputs.glob_dirs(prefix / "lib", "python3*")
            if inputs.is_dir(Path(d) / "site-packages")]


def is_wheel_underlay(prefix: Path) -> bool:
    """Whether `prefix` got its ROS packages from the PyPI wheels (not from apt or a build)."""
    for site in site_packages_dirs(prefix):
        if (site / "ros_wheels_bootstrapper").is_dir() or next(site.glob("ros_*.libs"), None):
            return True
    return False


def ros_distro(prefix: Path) -> str | None:
    """The distro named by the installed `ros-<distro>-*` meta wheels (e.g. `"jazzy"`)."""
    for site in site_packages_dirs(prefix):
        try:  # (by name: sorting Path objects costs more than listing the directory)
            names = sorted(fnmatch.filter(os.listdir(site), "ros_*_*-*.dist-info"))
        except OSError:
            continue
        for name in names:
            parts = name.split("-", 1)[0].split("_")  # ros_jazzy_rclpy-7.1.6.dist-info
            if len(parts) >= 3 and parts[1] in _KNOWN_DISTROS:
                return parts[1]
    return None


_KNOWN_DISTROS = frozenset({"humble", "iron", "jazzy", "kilted", "rolling"})


# ------------------------------------------------------------------------------ python


def _declare_python_library(facts: dict[str, str | None]) -> None:
    """What `_python_facts` looked at (it runs with the standard library only, maybe in
    another process): the interpreter's library directory and the library found there."""
    library = facts.get("library")
    if library:
        inputs.realpath(os.path.dirname(library))
        inputs.exists(library)


def _python_facts() -> dict[str, str | None]:
    """Run inside the venv's interpreter (in-process or via `python -c`): stdlib only."""
    import os
    import sys
    import sysconfig

    var = sysconfig.get_config_var
    library = None
    if var("Py_ENABLE_SHARED") and var("LIBDIR"):
        for name in (var("LDLIBRARY"), var("INSTSONAME")):
            if name and os.path.isfile(os.path.join(var("LIBDIR"), name)):
                library = os.path.join(var("LIBDIR"), name)
                break
    return {
        "version": f"{sys.version_info[0]}.{sys.version_info[1]}",
        "site_packages": sysconfig.get_path("platlib"),
        "include_dir": sysconfig.get_path("include"),
        "library": library,
    }


_python_cache: dict[str, VenvPython] = {}


def _venv_executable(prefix: Path) -> Path:
    for name in ("python3", "python"):
        candidate = prefix / "bin" / name
        if inputs.exists(candidate):
            return candidate
    raise UnderlayError(
        "the underlay has no Python interpreter",
        path=prefix / "bin",
        hint="create it with `python3 -m venv` and pip-install the ros-jazzy-* wheels into it",
    )


def venv_python(prefix: Path) -> VenvPython:
    """Interpreter facts for the venv at `prefix` (cached per process).

    In-process when the running interpreter is that venv's; otherwise one
    `python -E -c ...` with the bootstrap guard set, so it does not re-exec (`-S` is no
    option: Python 3.11 sets `sys.prefix` to the venv in `site`).
    """
    key = os.path.abspath(prefix)
    cached = _python_cache.get(key)
    if cached is not None:
        return cached
    executable = _venv_executable(prefix)
    facts: dict[str, str | None]
    if os.path.abspath(sys.prefix) == key:
        facts = _python_facts()
    else:
        script = f"import json\n{inspect.getsource(_python_facts)}\nprint(json.dumps(_python_facts()))\n"
        env = {k: v for k, v in os.environ.items() if k != "PYTHONHOME"}
        env[BOOTSTRAP_GUARD_VAR] = "1"
        import subprocess  # lazy: off a run whose venv's facts are known

        try:
            done = subprocess.run(
                [str(executable), "-E", "-c", script],
                capture_output=True,
                text=True,
                env=env,
                timeout=60,
                check=False,
            )
        except OSError as exc:
            raise UnderlayError(f"cannot run the underlay's Python: {exc}", path=executable) from exc
        if done.returncode != 0:
            raise UnderlayError(
                f"the underlay's Python failed: {done.stderr.strip()[-500:]}", path=executable
            )
        facts = json.loads(done.stdout)
    _declare_python_library(facts)
    result = VenvPython(
        version=str(facts["version"]),
        executable=executable,
        site_packages=Path(str(facts["site_packages"])),
        include_dir=Path(str(facts["include_dir"])),
        library=Path(facts["library"]) if facts["library"] else None,
    )
    _python_cache[key] = result
    return result


