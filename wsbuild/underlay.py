"""ROS 2 underlays installed from PyPI wheels into a virtualenv: detection, repair, environment.

`pip install ros-jazzy-rclpy ...` turns a virtualenv into a ROS underlay: the venv prefix
holds `share/ament_index/...`, `share/<pkg>/cmake/...`, `include/` and `lib/` like
`/opt/ros/jazzy` does.  The wheels were built under `/opt/python/cp3XX-cp3XX` in a
manylinux container, and some of their exported CMake files still name that machine:

* `share/<msgs>/cmake/export_<msgs>__rosidl_generator_pyExport.cmake` puts
  `/opt/python/cp311-cp311/include/python3.11` and
  `/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include` into
  `INTERFACE_INCLUDE_DIRECTORIES`.  CMake refuses to generate any project that links
  those targets ("Imported target ... includes non-existent path"), which is every
  `rosidl_generate_interfaces()` depending on a message package.
* `share/fastrtps/cmake/fastrtps-shared-targets.cmake` links `/usr/lib64/libtinyxml2.so`
  (`make: No rule to make target '/usr/lib64/libtinyxml2.so'` for anything linking rcl),
  although `libfastrtps.so` already carries its own bundled tinyxml2.
* `share/fastrtps/cmake/fastrtps-config.cmake` does `find_package(OpenSSL REQUIRED)` and
  links `OpenSSL::SSL`, so every rcl consumer needs the host's OpenSSL headers, although
  `libfastrtps.so` carries its own bundled OpenSSL.
* `share/ament_index/resource_index/parent_prefix_path/*` names `/opt/python/cp311-cp311`
  as the parent prefix (harmless for CMake, rewritten for consistency).

Two more wheel quirks are handled without touching the venv: the
`lib*__rosidl_generator_py.so` libraries (exported by every message package and linked by
rcl) do not link libpython, so C/C++ executables need it on their link line
(`cmake_arguments`); the pybind11_vendor wheel relies on PyPI's `pybind11`, whose CMake
config lives in site-packages (`cmake_prefixes`).

`repair_underlay` rewrites exactly the files listed first, inside the venv only, atomically and
idempotently; `scan_underlay` reports what it would change and caches a clean result in
`<venv>/.wsbuild/underlay.json` so repeated calls cost a few `stat`s.

The wheels' shared libraries live in `<venv>/lib` and in `site-packages/ros_*.libs`
(auditwheel copies of libssl, tinyxml2, spdlog, yaml, lttng-ust ...).  Their RPATHs point
outside the venv, so nothing loads without `LD_LIBRARY_PATH`.  The
`ros_wheels_bootstrapper.pth` file therefore makes every Python started in the venv
re-execute itself once with `LD_LIBRARY_PATH` extended, unless `BOOTSTRAP_GUARD_VAR` is set
in its environment; `build_environment` computes the same variables so that neither the
build nor the processes it starts pay for (or depend on) that re-exec.
"""

from __future__ import annotations

import inspect
import json
import os
import re
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path

from wsbuild.errors import UnderlayError

__all__ = [
    "BOOTSTRAP_GUARD_VAR",
    "EXTRA_REQUIREMENTS",
    "LINT_AUTO_SHIM_VERSION",
    "MARKER_RELPATH",
    "MissingPackage",
    "Problem",
    "VenvPython",
    "build_environment",
    "cmake_arguments",
    "cmake_prefixes",
    "find_cmake_package",
    "find_venv_underlay",
    "is_wheel_underlay",
    "library_dirs",
    "missing_packages",
    "repair_underlay",
    "ros_distro",
    "scan_underlay",
    "venv_python",
    "write_lint_auto_shim",
]

#: Set (to any non-empty value) in a child's environment, it stops
#: `ros_wheels_bootstrapper` from re-executing the interpreter.  Only set it together
#: with the `LD_LIBRARY_PATH` entries of `library_dirs`, or rclpy fails to import.
BOOTSTRAP_GUARD_VAR = "_ROS_WHEELS_BOOTSTRAP_COMPLETE"

#: Where the repair stamp lives, relative to the venv prefix.
MARKER_RELPATH = Path(".wsbuild") / "underlay.json"

#: Bumped whenever the repair rules change, so that older stamps are ignored.
RULES_VERSION = 1

#: Version written into the ament_lint_auto stand-in (see `write_lint_auto_shim`).
LINT_AUTO_SHIM_VERSION = "0.17.3"

#: Wheels the ros-jazzy-* metadata forgets: `find_package()` fails without them (the first
#: three for any ament_cmake / rosidl package, the gtest/gmock/pytest ones once
#: ament_cmake_ros is there, the vendors for `ament_add_gtest`/`ament_add_gmock`).
#: `missing_packages` finds them one level at a time; this is the whole list for Jazzy.
EXTRA_REQUIREMENTS = (
    "ros-jazzy-ament-package",
    "ros-jazzy-ament-cmake-include-directories",
    "ros-jazzy-ament-cmake-ros",
    "ros-jazzy-rosidl-core-generators",
    "ros-jazzy-ament-cmake-gtest",
    "ros-jazzy-ament-cmake-gmock",
    "ros-jazzy-ament-cmake-pytest",
    "ros-jazzy-gtest-vendor",
    "ros-jazzy-gmock-vendor",
)

_INDEX = Path("share", "ament_index", "resource_index")
_OPT_PYTHON = re.compile(
    r"/opt/python/cp(?P<major>\d)(?P<minor>\d+)-cp\d+[a-z]*(?P<rest>(?:/[A-Za-z0-9_.+\-/]*)?)"
)
_INCLUDE_REST = re.compile(r"/include/python\d+\.\d+[a-z]*(?P<tail>(?:/.*)?)$")
_SITE_REST = re.compile(r"/lib/python\d+\.\d+/(?:site|dist)-packages(?P<tail>(?:/.*)?)$")
_BIN_PYTHON_REST = re.compile(r"/bin/python[0-9.]*$")
_LINK_LIBRARIES = re.compile(r'(?P<head>^\s*INTERFACE_LINK_LIBRARIES\s+")(?P<value>[^"]*)(?P<tail>".*)$')
# libraries of the manylinux (AlmaLinux) build host; Debian/Ubuntu never use lib64
_HOST_LIBRARY = re.compile(r"^/usr/(?:local/)?lib64/[^;\s\"$<>]+\.(?:so|a)(?:\.[0-9.]+)?$")
_OPENSSL_REQUIRED = re.compile(r"find_package\(\s*OpenSSL\s+REQUIRED\s*\)")
_OPENSSL_GENEX = "$<$<BOOL:1>:OpenSSL::SSL"
_OPENSSL_GENEX_ESCAPED = r"\$<\$<BOOL:1>:OpenSSL::SSL"
_FIND_PACKAGE = re.compile(r"find_package\(\s*([A-Za-z0-9_]+)([^)]*)\)")
_EXPORTED_DEPENDENCIES = re.compile(r'set\(_exported_dependencies\s+"([^"]*)"\)')


@dataclass(frozen=True)
class Problem:
    """One defect in an underlay file.

    `line` is 1-based; `text` is the offending line (stripped, shortened); `fix` says what
    the repair does, or for `repairable=False` problems what the user has to do.
    """

    path: Path
    line: int
    text: str
    fix: str
    repairable: bool = True


@dataclass(frozen=True)
class MissingPackage:
    """A CMake package that installed underlay files `find_package()` but nobody installed."""

    name: str
    required_by: tuple[str, ...]
    requirement: str


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
        return (self.include_dir / "Python.h").is_file()


# ---------------------------------------------------------------------------- detection


def _is_ament_prefix(prefix: Path) -> bool:
    return (prefix / _INDEX / "packages").is_dir()


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
        if (venv / "pyvenv.cfg").is_file():
            candidates.append(venv)
    if sys.prefix != sys.base_prefix:
        candidates.append(Path(sys.prefix))
    for candidate in candidates:
        if _is_ament_prefix(candidate):
            return Path(os.path.abspath(candidate))
    return None


def _site_packages_dirs(prefix: Path) -> list[Path]:
    return sorted(p for p in (prefix / "lib").glob("python3*/site-packages") if p.is_dir())


def is_wheel_underlay(prefix: Path) -> bool:
    """Whether `prefix` got its ROS packages from the PyPI wheels (not from apt or a build)."""
    for site in _site_packages_dirs(prefix):
        if (site / "ros_wheels_bootstrapper").is_dir() or next(site.glob("ros_*.libs"), None):
            return True
    return False


def ros_distro(prefix: Path) -> str | None:
    """The distro named by the installed `ros-<distro>-*` meta wheels (e.g. `"jazzy"`)."""
    for site in _site_packages_dirs(prefix):
        for info in sorted(site.glob("ros_*_*-*.dist-info")):
            parts = info.name.split("-", 1)[0].split("_")  # ros_jazzy_rclpy-7.1.6.dist-info
            if len(parts) >= 3 and parts[1] in _KNOWN_DISTROS:
                return parts[1]
    return None


_KNOWN_DISTROS = frozenset({"humble", "iron", "jazzy", "kilted", "rolling"})


# ------------------------------------------------------------------------------ python


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
        if candidate.exists():
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
    result = VenvPython(
        version=str(facts["version"]),
        executable=executable,
        site_packages=Path(str(facts["site_packages"])),
        include_dir=Path(str(facts["include_dir"])),
        library=Path(facts["library"]) if facts["library"] else None,
    )
    _python_cache[key] = result
    return result


# ------------------------------------------------------------------------------ rules


@dataclass(frozen=True)
class _Edit:
    line: int
    text: str
    fix: str


# A rule takes the file text and returns (new text, edits).
_Rule = Callable[[str], "tuple[str, list[_Edit]]"]


def _opt_python_rule(prefix: Path, python: VenvPython) -> _Rule:
    """`/opt/python/cp3XX-cp3XX/...` -> the venv's include dir / site-packages / python / prefix."""

    def target(match: re.Match[str]) -> str:
        rest = match["rest"]
        m = _INCLUDE_REST.match(rest)
        if m:
            return str(python.include_dir) + m["tail"]
        m = _SITE_REST.match(rest)
        if m:
            tail = m["tail"]
            new = str(python.site_packages) + tail
            if "/numpy/_core/include" in tail and not os.path.isdir(new):
                legacy = new.replace("/numpy/_core/include", "/numpy/core/include")
                if os.path.isdir(legacy):  # numpy < 2
                    new = legacy
            return new
        if _BIN_PYTHON_REST.match(rest):
            return str(python.executable)
        return str(prefix) + rest

    def rule(text: str) -> tuple[str, list[_Edit]]:
        if "/opt/python/" not in text:
            return text, []
        edits: list[_Edit] = []
        out: list[str] = []
        for number, line in enumerate(text.splitlines(keepends=True), 1):
            if "/opt/python/" in line:
                replaced = _OPT_PYTHON.sub(target, line)
                if replaced != line:
                    pairs = dict.fromkeys((m.group(0), target(m)) for m in _OPT_PYTHON.finditer(line))
                    fix = "; ".join(f"replace {old} with {new}" for old, new in pairs)
                    edits.append(_Edit(number, _shorten(line.strip()), fix))
                    line = replaced
            out.append(line)
        return "".join(out), edits

    return rule


def _host_library_rule(text: str) -> tuple[str, list[_Edit]]:
    """Drop `INTERFACE_LINK_LIBRARIES` entries naming build-host `/usr/lib64` libraries that
    do not exist here.

    (`/usr/lib64/libtinyxml2.so` from the manylinux build host; `libfastrtps.so` already
    needs its bundled copy, so consumers lose nothing.)
    """
    if "INTERFACE_LINK_LIBRARIES" not in text:
        return text, []
    edits: list[_Edit] = []
    out: list[str] = []
    for number, line in enumerate(text.splitlines(keepends=True), 1):
        m = _LINK_LIBRARIES.match(line.rstrip("\n"))
        if m:
            items = m["value"].split(";")
            gone = [i for i in items if _HOST_LIBRARY.match(i) and not os.path.exists(i)]
            if gone:
                kept = [i for i in items if i not in gone]
                newline = m["head"] + ";".join(kept) + m["tail"] + ("\n" if line.endswith("\n") else "")
                edits.append(
                    _Edit(number, _shorten(line.strip()), f"drop {', '.join(gone)} (not on this machine)")
                )
                line = newline
        out.append(line)
    return "".join(out), edits


def _openssl_rule(text: str) -> tuple[str, list[_Edit]]:
    """fastrtps: make the host OpenSSL optional (the wheel bundles its own libssl/libcrypto)."""
    edits: list[_Edit] = []
    out: list[str] = []
    for number, line in enumerate(text.splitlines(keepends=True), 1):
        new = line
        if _OPENSSL_REQUIRED.search(new):
            new = _OPENSSL_REQUIRED.sub("find_package(OpenSSL QUIET)", new)
        if _OPENSSL_GENEX_ESCAPED in new:
            new = new.replace(_OPENSSL_GENEX_ESCAPED, r"\$<\$<TARGET_EXISTS:OpenSSL::SSL>:OpenSSL::SSL")
        elif _OPENSSL_GENEX in new:
            new = new.replace(_OPENSSL_GENEX, "$<$<TARGET_EXISTS:OpenSSL::SSL>:OpenSSL::SSL")
        if new != line:
            edits.append(
                _Edit(
                    number,
                    _shorten(line.strip()),
                    "make OpenSSL optional: find_package(OpenSSL QUIET), link OpenSSL::SSL only if found",
                )
            )
        out.append(new)
    return "".join(out), edits


def _shorten(text: str, limit: int = 200) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


# ------------------------------------------------------------------------------- files


def _under(prefix: Path, path: Path) -> bool:
    try:
        return path.resolve().is_relative_to(prefix.resolve())
    except OSError:
        return False


def _cmake_files(prefix: Path) -> Iterator[Path]:
    """The exported CMake files of the underlay (the only place baked paths matter)."""
    share = prefix / "share"
    roots: list[Path] = []
    if share.is_dir():
        with os.scandir(share) as entries:
            roots.extend(Path(e.path) / "cmake" for e in entries if e.is_dir(follow_symlinks=False))
    lib = prefix / "lib"
    if lib.is_dir():
        roots.append(lib / "cmake")
        with os.scandir(lib) as entries:
            roots.extend(
                Path(e.path) / "cmake"
                for e in entries
                if e.is_dir(follow_symlinks=False) and not e.name.startswith("python")
            )
    for root in roots:
        if not root.is_dir():
            continue
        for dirpath, _dirnames, filenames in os.walk(root):
            for name in sorted(filenames):
                if name.endswith(".cmake"):
                    yield Path(dirpath) / name


def _parent_prefix_files(prefix: Path) -> Iterator[Path]:
    folder = prefix / _INDEX / "parent_prefix_path"
    if folder.is_dir():
        with os.scandir(folder) as entries:
            for entry in sorted(entries, key=lambda e: e.name):
                if entry.is_file(follow_symlinks=False):
                    yield Path(entry.path)


def _rules_for(path: Path, prefix: Path, python: VenvPython) -> list[_Rule]:
    rules: list[_Rule] = [_opt_python_rule(prefix, python)]
    if path.suffix == ".cmake":
        rules.append(_host_library_rule)
        if path.parent == prefix / "share" / "fastrtps" / "cmake":
            rules.append(_openssl_rule)
    return rules


_QUICK = (b"/opt/python/", b"/lib64/", b"OpenSSL")


def _analyse(prefix: Path, python: VenvPython) -> Iterator[tuple[Path, str, str, list[_Edit]]]:
    """(path, old text, new text, edits) for every file some rule wants to change."""
    for path in [*_cmake_files(prefix), *_parent_prefix_files(prefix)]:
        try:
            data = path.read_bytes()
        except OSError:
            continue
        if not any(token in data for token in _QUICK):
            continue
        if path.is_symlink() or not _under(prefix, path):
            continue
        try:
            old = data.decode("utf-8")
        except UnicodeDecodeError:
            continue
        new = old
        edits: list[_Edit] = []
        for rule in _rules_for(path, prefix, python):
            new, more = rule(new)
            edits.extend(more)
        if new != old:
            yield path, old, new, edits


def _atomic_write(path: Path, text: str) -> None:
    """Replace `path` by a fully written temp file in the same directory, keeping its mode."""
    try:
        mode = path.stat().st_mode & 0o7777
    except FileNotFoundError:
        mode = 0o644
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".wsbuild-tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


# ---------------------------------------------------------------------- stamp / marker


def _stamp(prefix: Path) -> list[int]:
    """Changes whenever pip installs, upgrades or removes anything in the venv."""
    values: list[int] = [RULES_VERSION]
    for path in [prefix / _INDEX / "packages", *_site_packages_dirs(prefix)]:
        try:
            values.append(path.stat().st_mtime_ns)
            with os.scandir(path) as entries:  # mtimes can be coarse: count entries too
                values.append(sum(1 for _ in entries))
        except OSError:
            values.extend((-1, -1))
    return values


def _read_marker(prefix: Path) -> dict[str, object] | None:
    try:
        data = json.loads((prefix / MARKER_RELPATH).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _write_marker(prefix: Path, stamp: list[int], python: VenvPython, repaired: list[Path]) -> None:
    marker = prefix / MARKER_RELPATH
    payload = {
        "rules": RULES_VERSION,
        "stamp": stamp,
        "clean": True,
        "python": {k: (str(v) if isinstance(v, Path) else v) for k, v in asdict(python).items()},
        "repaired": sorted(str(p.relative_to(prefix)) for p in repaired),
    }
    previous = _read_marker(prefix) or {}
    earlier = previous.get("repaired")
    if isinstance(earlier, list):  # keep the history of what was ever rewritten
        payload["repaired"] = sorted({*map(str, earlier), *(str(p.relative_to(prefix)) for p in repaired)})
    try:
        marker.parent.mkdir(parents=True, exist_ok=True)
        _atomic_write(marker, json.dumps(payload, indent=1, sort_keys=True) + "\n")
    except OSError:
        pass  # a read-only venv just does not cache


def _headers_problem(prefix: Path, python: VenvPython) -> list[Problem]:
    if python.has_headers or not (prefix / "share" / "rosidl_generator_py").is_dir():
        return []
    return [
        Problem(
            path=python.include_dir / "Python.h",
            line=0,
            text="missing",
            fix=(
                f"install the Python {python.version} development headers for the venv's base "
                f"interpreter (Debian: apt-get install python{python.version}-dev); "
                "rosidl_generate_interfaces builds Python extensions"
            ),
            repairable=False,
        )
    ]


# ------------------------------------------------------------------------ public: scan


def scan_underlay(prefix: Path, *, use_cache: bool = True) -> list[Problem]:
    """What `repair_underlay` would fix in the wheel underlay at `prefix`, plus unfixable problems.

    Reads only the exported CMake files (`share/*/cmake`, `lib/cmake`, `lib/*/cmake`) and
    `parent_prefix_path` index entries.  A clean result is recorded in
    `<prefix>/.wsbuild/underlay.json` with a stamp of the venv's package directories, so
    the next call with an unchanged venv costs a few `stat`s.
    """
    prefix = Path(os.path.abspath(prefix))
    if not _is_ament_prefix(prefix):
        raise UnderlayError(
            "not a ROS underlay (no share/ament_index/resource_index/packages)",
            path=prefix,
            hint="pip-install ros-jazzy-* wheels into the venv",
        )
    stamp = _stamp(prefix)
    marker = _read_marker(prefix) if use_cache else None
    if marker and marker.get("stamp") == stamp and marker.get("clean") is True:
        python = _python_from_marker(prefix, marker) or venv_python(prefix)
        return _headers_problem(prefix, python)
    python = venv_python(prefix)
    problems = [
        Problem(path=path, line=edit.line, text=edit.text, fix=edit.fix)
        for path, _old, _new, edits in _analyse(prefix, python)
        for edit in edits
    ]
    if not problems:
        _write_marker(prefix, stamp, python, [])
    return problems + _headers_problem(prefix, python)


def _python_from_marker(prefix: Path, marker: Mapping[str, object]) -> VenvPython | None:
    facts = marker.get("python")
    if not isinstance(facts, dict):
        return None
    try:
        return VenvPython(
            version=str(facts["version"]),
            executable=Path(str(facts["executable"])),
            site_packages=Path(str(facts["site_packages"])),
            include_dir=Path(str(facts["include_dir"])),
            library=Path(str(facts["library"])) if facts.get("library") else None,
        )
    except KeyError:
        return None


# ---------------------------------------------------------------------- public: repair


def repair_underlay(prefix: Path) -> list[Path]:
    """Rewrite the broken files of the wheel underlay at `prefix` in place; return them.

    Every write is atomic (temp file + rename in the same directory, mode kept) and stays
    inside `prefix`.  Running it again changes nothing and returns `[]`.  The stamp is
    recorded so that `scan_underlay` is free afterwards.
    """
    prefix = Path(os.path.abspath(prefix))
    if not _is_ament_prefix(prefix):
        raise UnderlayError("not a ROS underlay (no share/ament_index/resource_index/packages)", path=prefix)
    stamp = _stamp(prefix)
    python = venv_python(prefix)
    changed: list[Path] = []
    for path, _old, new, _edits in _analyse(prefix, python):
        if not _under(prefix, path):  # _analyse checks too; never write outside the venv
            continue
        try:
            _atomic_write(path, new)
        except OSError as exc:
            raise UnderlayError(
                f"cannot rewrite underlay file: {exc.strerror or exc}",
                path=path,
                hint="run wsbuild as a user who may write to the virtualenv",
            ) from exc
        changed.append(path)
    _write_marker(prefix, stamp, python, changed)
    return changed


# --------------------------------------------------------------- missing dependencies


def _resolvable(prefix: Path, name: str) -> bool:
    share = prefix / "share" / name
    for folder in (share / "cmake", share, prefix / "lib" / "cmake" / name, prefix / "lib" / name / "cmake"):
        if (folder / f"{name}Config.cmake").is_file() or (folder / f"{name}-config.cmake").is_file():
            return True
    return (prefix / _INDEX / "packages" / name).is_file()


def missing_packages(prefix: Path) -> list[MissingPackage]:
    """ROS CMake packages that installed CMake files `find_package()` (not QUIET, or listed
    in an `ament_export_dependencies` extras file) but that are not installed: the wheels' metadata forgets several (`ament_cmake_include_directories`,
    `ament_cmake_ros`, `rosidl_core_generators`, `ament_cmake_gtest` ...).

    Only lower-case names are considered (ROS package names); system packages such as
    `Python3` or `OpenSSL` are CMake's business.  `requirement` is the PyPI name.
    """
    prefix = Path(os.path.abspath(prefix))
    distro = ros_distro(prefix) or "jazzy"
    wanted: dict[str, set[str]] = {}
    find_modules: set[str] = set()  # Find<name>.cmake shipped by *_cmake_module / vendor packages
    for path in _cmake_files(prefix):
        if path.name.startswith("Find"):
            find_modules.add(path.name[4:-6])
        try:
            text = path.read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        if "find_package" not in text:
            continue
        rel = path.relative_to(prefix).parts
        owner = rel[2] if rel[:2] == ("lib", "cmake") else rel[1]
        names: list[str] = []
        for raw in text.splitlines():
            line = raw.split("#", 1)[0]
            for match in _FIND_PACKAGE.finditer(line):
                name, args = match.group(1), match.group(2).split()
                if "QUIET" not in args or "REQUIRED" in args:
                    names.append(name)
            # ament_export_dependencies(): find_package("${_dep}" QUIET REQUIRED) in a loop
            for match in _EXPORTED_DEPENDENCIES.finditer(line):
                names.extend(n for n in match.group(1).split(";") if n)
        for name in names:
            if name == name.lower():
                wanted.setdefault(name, set()).add(owner)
    result = []
    for name in sorted(wanted):
        if name not in find_modules and not _resolvable(prefix, name):
            result.append(
                MissingPackage(
                    name=name,
                    required_by=tuple(sorted(wanted[name])),
                    requirement=f"ros-{distro}-{name.replace('_', '-')}",
                )
            )
    return result


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
    for site in _site_packages_dirs(prefix):
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


def cmake_prefixes(prefix: Path) -> list[Path]:
    """`CMAKE_PREFIX_PATH` entries of the underlay: the venv, and the `pybind11` PyPI package's
    own prefix (the pybind11_vendor wheel depends on it instead of vendoring pybind11, and
    its `pybind11Config.cmake` lives in `site-packages/pybind11/share/cmake/pybind11`)."""
    prefix = Path(os.path.abspath(prefix))
    result = [prefix]
    for site in _site_packages_dirs(prefix):
        if (site / "pybind11" / "share" / "cmake" / "pybind11").is_dir():
            result.append(site / "pybind11")
    return result


def _prepend(value: str | None, entries: Iterable[str]) -> str:
    current = [p for p in (value or "").split(os.pathsep) if p]
    new = [e for e in entries if e not in current]
    return os.pathsep.join(new + current)


def build_environment(prefix: Path, environ: Mapping[str, str]) -> dict[str, str]:
    """The variables to set (their complete new values) for builds and for ROS processes.

    Equivalent of sourcing the underlay's setup script: prepends the venv to `PATH`,
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
        "PATH": _prepend(environ.get("PATH"), [str(prefix / "bin")]),
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


# -------------------------------------------------------------------- ament_lint_auto


def find_cmake_package(name: str, prefixes: Iterable[Path]) -> Path | None:
    """The directory holding `<name>Config.cmake` / `<name>-config.cmake` in `prefixes`, if any
    (the common ament layouts only, not CMake's full search procedure)."""
    for prefix in prefixes:
        for folder in (
            prefix / "share" / name / "cmake",
            prefix / "share" / name,
            prefix / "lib" / "cmake" / name,
            prefix / "lib" / name / "cmake",
        ):
            if (folder / f"{name}Config.cmake").is_file() or (folder / f"{name}-config.cmake").is_file():
                return folder
    return None


_LINT_AUTO_CONFIG = """\
# Generated by wsbuild: a stand-in for ament_lint_auto, which is not available as a
# PyPI wheel.  It finds the package's <test_depend>s like the real one (QUIET), but
# registers no linters.  wsbuild appends its prefix to CMAKE_PREFIX_PATH only when no
# real ament_lint_auto is installed, so a real one always wins.
set(ament_lint_auto_FOUND TRUE)
set(ament_lint_auto_VERSION "{version}")
set(AMENT_LINT_AUTO_IS_WSBUILD_SHIM TRUE)

macro(ament_lint_auto_find_test_dependencies)
  if(NOT _AMENT_PACKAGE_NAME)
    ament_package_xml()
  endif()
  foreach(_wsbuild_lint_dep ${{${{PROJECT_NAME}}_TEST_DEPENDS}})
    if(NOT _wsbuild_lint_dep STREQUAL "ament_lint_auto")
      find_package(${{_wsbuild_lint_dep}} QUIET)
    endif()
  endforeach()
  unset(_wsbuild_lint_dep)
endmacro()
"""

_LINT_AUTO_VERSION_FILE = """\
# Generated by wsbuild: the ament_lint_auto stand-in accepts any requested version.
set(PACKAGE_VERSION "{version}")
set(PACKAGE_VERSION_COMPATIBLE TRUE)
set(PACKAGE_VERSION_EXACT FALSE)
"""


def write_lint_auto_shim(directory: Path) -> Path:
    """Write the ament_lint_auto stand-in under `directory` (idempotent); return the prefix
    to append to `CMAKE_PREFIX_PATH`.

    Use it when `find_cmake_package("ament_lint_auto", prefixes)` finds nothing: packages
    then configure with `BUILD_TESTING` left ON (their gtest/pytest tests still build and
    run), only the linters are skipped.  `directory` should be wsbuild-owned (e.g. under
    the build base), never the user's venv.
    """
    folder = directory / "share" / "ament_lint_auto" / "cmake"
    files = {
        folder / "ament_lint_autoConfig.cmake": _LINT_AUTO_CONFIG.format(version=LINT_AUTO_SHIM_VERSION),
        folder / "ament_lint_autoConfigVersion.cmake": _LINT_AUTO_VERSION_FILE.format(
            version=LINT_AUTO_SHIM_VERSION
        ),
    }
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for path, text in files.items():
            if not path.is_file() or path.read_text(encoding="utf-8") != text:
                _atomic_write(path, text)
    except OSError as exc:
        raise UnderlayError(f"cannot write the ament_lint_auto stand-in: {exc}", path=folder) from exc
    return directory


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


def prepare_underlay(
    environ: Mapping[str, str],
    *,
    executable: str,
    repair: bool,
    shim_dir: Path,
    notice: Callable[[str], None],
) -> PreparedUnderlay:
    """Detect the ROS underlay, repair a wheel venv if needed, and compute the build environment.

    Also makes `find_package(ament_lint_auto)` work when no real ament_lint_auto is installed
    (no wheel exists): a stand-in that registers no linters is appended to CMAKE_PREFIX_PATH.
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
        if problems:
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
    has_ament = any(_is_ament_prefix(p) for p in prefixes)
    if has_ament and find_cmake_package("ament_lint_auto", prefixes) is None:
        shim = write_lint_auto_shim(shim_dir)
        current = env.get("CMAKE_PREFIX_PATH", "")
        env["CMAKE_PREFIX_PATH"] = os.pathsep.join(p for p in (current, str(shim)) if p)
    return PreparedUnderlay(environ=env, venv=venv, cmake_args=cmake_args,
                            venv_changes=tuple(sorted(changes.items())))
