"""The long-lived process that learns setup() arguments: run by the target interpreter as a script.

wsbuild starts it once per interpreter (see `wsbuild.build_types.pybuild.setup_py`) and talks JSON lines over its
stdin/stdout. It imports setuptools once; each `read` request forks a child that executes the
package's setup.py with `Distribution.run_commands` replaced, so setuptools itself parses
setup.py, setup.cfg and pyproject.toml, runs only `egg_info` (into the build directory) and
reports what `build_py`, `install_data` and `install_scripts` would install. The child never
copies a file: wsbuild does that. This file must not import wsbuild (the target interpreter may
not have it) and must keep working on Python 3.10.
"""

from __future__ import annotations

import sys

# `python helper.py` puts the wsbuild package directory first on sys.path; a setup.py must
# not be able to import wsbuild's modules by accident.
del sys.path[0]

import json  # noqa: E402
import os  # noqa: E402
import signal  # noqa: E402
import traceback  # noqa: E402

#: setup.cfg sections whose options change what a real build produces; the fast path cannot
#: represent them, so such packages take the PEP 517 fallback.
_BUILD_SECTIONS = ("build_ext", "build_clib", "build_scripts", "install_lib", "install_data",
                   "install_headers")
#: `[install]` options wsbuild applies; any other is reported as ignored
_INSTALL_KEYS_HONOURED = frozenset({"install_scripts", "compile"})

_STARTUP_SYS_PATH = list(sys.path)
_STARTUP_PYTHONPATH = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]


def _reply(channel, message: dict) -> None:
    channel.write(json.dumps(message) + "\n")
    channel.flush()


def _import_setuptools() -> dict:
    # Import everything a request touches once, so each forked child starts warm.
    import importlib

    import setuptools
    import setuptools.dist  # noqa: F401

    for module in ("runpy", "py_compile", "importlib.util", "setuptools.command.build_py", "setuptools.command.egg_info",
                   "setuptools.command.sdist", "setuptools.config.setupcfg",
                   "setuptools.config.pyprojecttoml", "setuptools.config._apply_pyprojecttoml",
                   "setuptools.discovery"):
        try:
            importlib.import_module(module)
        except ImportError:  # an older setuptools: the child imports what it needs
            pass

    _warm_up()
    _cache_entry_points()
    return {"ready": True, "setuptools": setuptools.__version__,
            "python": f"{sys.version_info[0]}.{sys.version_info[1]}"}


def _warm_up() -> None:
    # Building a Distribution loads setuptools' entry points (setup keywords, finalizers,
    # commands); doing it once here leaves importlib.metadata's caches warm for every child.
    import warnings

    import setuptools.dist

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dist = setuptools.dist.Distribution({"name": "wsbuild-warm-up", "version": "0",
                                             "py_modules": []})
        dist.get_command_class("egg_info")
        dist.get_command_class("build_py")


#: path entry -> [(normalized distribution name, its entry points)] for the interpreter's own
#: site directories, scanned once in the helper and inherited by every child
_ENTRY_POINTS_BY_PATH: dict = {}


def _scan_entry_points(entry: str) -> list:
    import importlib.metadata

    found = []
    for dist in importlib.metadata.distributions(path=[entry]):
        name = getattr(dist, "_normalized_name", None) or dist.metadata["Name"]
        found.append((name, list(dist.entry_points)))
    return found


def _cache_entry_points() -> None:
    """Make `importlib.metadata.entry_points(group=...)` cheap in children.

    setuptools asks for entry points about eight times per setup.py, and each call reads
    every distribution's metadata on sys.path (hundreds in a ROS virtualenv). The
    interpreter's own site directories are scanned once here; directories a request adds
    through PYTHONPATH (the workspace's prefixes) are still scanned fresh by each child.
    """
    import importlib.metadata

    for entry in _STARTUP_SYS_PATH:
        if entry not in _STARTUP_PYTHONPATH:
            _ENTRY_POINTS_BY_PATH[entry] = _scan_entry_points(entry)
    original = importlib.metadata.entry_points
    merged_for_path: dict = {}

    def entry_points(**params):
        if not params:  # the deprecated dict-like form: leave it to the original
            return original()
        key = tuple(sys.path)
        merged = merged_for_path.get(key)
        if merged is None:
            seen = set()
            merged = []
            for entry in key:
                by_path = _ENTRY_POINTS_BY_PATH.get(entry)
                if by_path is None:
                    by_path = _ENTRY_POINTS_BY_PATH[entry] = _scan_entry_points(entry)
                for name, points in by_path:
                    if name not in seen:  # the first distribution of a name wins
                        seen.add(name)
                        merged.extend(points)
            merged_for_path[key] = merged
        return importlib.metadata.EntryPoints(merged).select(**params)

    importlib.metadata.entry_points = entry_points


def _child_sys_path(source_dir: str, env: dict) -> list:
    # Python puts PYTHONPATH right after the script directory; swap the helper's PYTHONPATH
    # for the request's so a setup.py sees the package's own dependency prefixes.
    requested = [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]
    rest = [p for p in _STARTUP_SYS_PATH if p not in _STARTUP_PYTHONPATH]
    return [source_dir, *requested, *rest]


def _normalize_data_files(data_files) -> list:
    from setuptools._distutils.util import convert_path

    result = []
    for entry in data_files or ():
        if isinstance(entry, str):
            result.append(["", [convert_path(entry)]])
        else:
            directory, sources = entry
            result.append([convert_path(directory), [convert_path(s) for s in sources]])
    return result


def _fallback_reasons(dist) -> list:
    import setuptools.dist

    reasons = []
    if type(dist) is not setuptools.dist.Distribution:
        reasons.append(f"custom distclass {type(dist).__name__}")
    custom = sorted(
        name for name, klass in (dist.cmdclass or {}).items()
        if not getattr(klass, "__module__", "").startswith(("setuptools.", "distutils."))
    )
    if custom:
        reasons.append("cmdclass overrides " + ", ".join(custom))
    if dist.has_ext_modules():
        reasons.append("ext_modules")
    if dist.has_c_libraries():
        reasons.append("libraries")
    if dist.has_headers():
        reasons.append("headers")
    if getattr(dist, "setup_requires", None):
        reasons.append("setup_requires")
    if getattr(dist, "namespace_packages", None):
        reasons.append("namespace_packages")
    for section in _BUILD_SECTIONS:
        if dist.command_options.get(section):
            reasons.append(f"setup.cfg [{section}] options")
    return reasons


def _plan(dist, result: dict) -> None:
    """Fill `result` with what a build and install of `dist` would produce."""
    result["name"] = dist.get_name()
    result["version"] = dist.get_version()
    result["data_files"] = _normalize_data_files(dist.data_files)
    result["scripts"] = [os.path.abspath(s) for s in (dist.scripts or ())]
    install = dist.get_option_dict("install")
    develop = dist.get_option_dict("develop")
    result["install_scripts"] = install.get("install_scripts", (None, None))[1]
    result["develop_script_dir"] = develop.get("script_dir", (None, None))[1]
    result["ignored_install_options"] = sorted(set(install) - _INSTALL_KEYS_HONOURED)
    result["fallback"] = _fallback_reasons(dist)
    if result["fallback"]:
        # The real build will run; still map sources to destinations (with setuptools' own
        # build_py, not a customised one) so a symlink install can link verbatim copies.
        try:
            from setuptools.command.build_py import build_py as plain_build_py

            build_py = plain_build_py(dist)
            build_py.ensure_finalized()
            _module_files(build_py, build_py.get_data_files_without_manifest(), result)
        except Exception:  # noqa: BLE001 - best effort only
            traceback.print_exc()
        return

    dist.run_command("egg_info")
    egg_info = dist.get_command_obj("egg_info")
    result["egg_info_dir"] = os.path.abspath(egg_info.egg_info)
    result["egg_info_basename"] = _egg_basename(egg_info) + ".egg-info"
    build_py = dist.get_command_obj("build_py")
    build_py.ensure_finalized()
    _module_files(build_py, build_py.data_files, result)


def _egg_basename(egg_info) -> str:
    try:
        return egg_info._get_egg_basename()  # what install_egg_info names the directory
    except AttributeError:  # older setuptools
        # pkg_resources' to_filename, as install_egg_info of that era used it
        version = f"{sys.version_info[0]}.{sys.version_info[1]}"
        name = egg_info.egg_name.replace("-", "_")
        return f"{name}-{egg_info.egg_version.replace('-', '_')}-py{version}"


def _module_files(build_py, data_files, result: dict) -> None:
    # keyed by destination: a later entry overwrites an earlier one, as copying would
    files = {}
    for package, module, module_file in build_py.find_all_modules():
        dest = "/".join([*filter(None, package.split(".")), module + ".py"])
        files[dest] = [dest, os.path.abspath(module_file), package]
    for package, src_dir, _build_dir, filenames in data_files:
        for filename in filenames:
            dest = "/".join([*filter(None, package.split(".")), filename.replace(os.sep, "/")])
            files[dest] = [dest, os.path.abspath(os.path.join(src_dir, filename)), package]
    result["files"] = sorted(files.values())
    result["packages"] = sorted(
        [package, os.path.abspath(build_py.get_package_dir(package))]
        for package in (build_py.distribution.packages or ())
    )


def _run_setup(req: dict) -> dict:
    import runpy

    import setuptools
    import setuptools.dist

    result: dict = {}
    captured: list = []
    original_run_commands = setuptools.dist.Distribution.run_commands

    def run_commands(dist) -> None:
        if captured:
            result.setdefault("fallback", []).append("setup() is called more than once")
            return
        captured.append(dist)
        _plan(dist, result)

    def install_setup_requires(attrs) -> None:
        # fetching setup_requires would reach for the network; the fallback reports them
        return None

    setuptools.dist.Distribution.run_commands = run_commands
    setuptools._install_setup_requires = install_setup_requires
    sys.argv = ["setup.py", "egg_info", "--egg-base", req["egg_base"]]
    # what setup.py imports writes no bytecode beside its sources (a helper module outside the
    # package, the package's own __init__): reading a package's metadata changes no directory
    # (a new __pycache__ would be a change of its listing). The install's byte-compiling is a
    # request of its own (py_compile, which this flag does not stop).
    writing_bytecode, sys.dont_write_bytecode = sys.dont_write_bytecode, True
    try:
        if os.path.exists("setup.py"):
            runpy.run_path("setup.py", run_name="__main__")
        else:
            # what setuptools.build_meta does for a project without setup.py
            setuptools.setup()
    except SystemExit as exc:
        if exc.code not in (None, 0) or not captured:
            raise RuntimeError(f"setup.py exited with {exc.code!r}") from None
    finally:
        sys.dont_write_bytecode = writing_bytecode
        setuptools.dist.Distribution.run_commands = original_run_commands
    if not captured:
        result.setdefault("fallback", []).append("setup.py does not call setup()")
    return result


def _child(req: dict, channel_fd: int) -> int:
    os.close(channel_fd)
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    log = os.open(req["log"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    os.dup2(log, 1)
    os.dup2(log, 2)
    os.chdir(req["source_dir"])
    os.environ.clear()
    os.environ.update(req["env"])
    hook = _start_observing(req["env"])
    sys.path[:] = [p for p in _child_sys_path(req["source_dir"], req["env"]) if p != hook]
    try:
        result = _run_setup(req)
    except BaseException as exc:  # a broken setup.py must not take the helper down
        traceback.print_exc()
        result = {"error": f"{type(exc).__name__}: {exc}"}
    sys.stdout.flush()
    sys.stderr.flush()
    tmp = req["result"] + ".tmp"
    with open(tmp, "w", encoding="utf-8") as handle:
        json.dump(result, handle)
    os.replace(tmp, req["result"])
    return 0


def _observer():
    """The step observer's switch, when wsbuild started this helper with it loaded (an
    observed build: wsbuild/observe/interposer.c), else None."""
    if not os.environ.get("LD_PRELOAD"):
        return None
    try:
        import ctypes

        return ctypes.CDLL(None).wsobserve_set_dir
    except (ImportError, OSError, AttributeError):
        return None


_SET_DIR = None


def _stop_observing() -> None:
    """After the helper imported setuptools (what it read then is each package's too): the
    helper observes nothing until a request's child starts."""
    if _SET_DIR is not None:
        _SET_DIR(None)
    os.environ.pop("WSOBSERVE_DIR", None)
    state = getattr(type(os.environ), "_wsobserve_state", None)
    if state is not None:  # the Python hook, loaded when the helper started
        state.update(dir=None, pid=-1, fd=-1)


def _start_observing(env: dict):
    """In a request's child, when the request is observed: the library writes into the
    request's directory from now on, and the Python hook (the first entry of the request's
    PYTHONPATH) observes os.environ and the import system. Returns the hook's directory."""
    directory = env.get("WSOBSERVE_DIR")
    if _SET_DIR is None or not directory:
        return None
    _SET_DIR(directory.encode("utf-8", "surrogateescape"))
    hook_dir = env.get("PYTHONPATH", "").split(os.pathsep)[0]
    hook = os.path.join(hook_dir, "sitecustomize.py")
    if os.path.isfile(hook):
        import runpy

        runpy.run_path(hook, run_name="wsobserve")["_observe"]()
    return hook_dir


def _read(req: dict, channel) -> dict:
    pid = os.fork()
    if pid == 0:
        code = 70
        try:
            code = _child(req, channel.fileno())
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    return {"status": os.waitstatus_to_exitcode(status)}


def _compile(req: dict) -> dict:
    import importlib.util
    import py_compile

    errors = []
    for path, display in req["files"]:
        try:
            # checked by the source's hash, not its time: an install restored from the cache,
            # or whose times were set, keeps bytecode Python trusts (by time it would write
            # the file again at the first import, and the install would no longer be the
            # one recorded)
            py_compile.compile(path, cfile=importlib.util.cache_from_source(path), dfile=display,
                               doraise=True,
                               invalidation_mode=py_compile.PycInvalidationMode.CHECKED_HASH)
        except (py_compile.PyCompileError, OSError) as exc:
            errors.append(f"{display}: {exc}")
    return {"status": 0, "errors": errors}


def main() -> int:
    # The reply channel is a private copy of stdout; fd 1 itself goes to stderr so that
    # nothing printed by imported code can corrupt the protocol.
    channel = os.fdopen(os.dup(1), "w", encoding="utf-8")
    os.dup2(2, 1)
    # wsbuild stops this process; a terminal Ctrl-C is wsbuild's to handle.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    global _SET_DIR
    _SET_DIR = _observer()
    try:
        hello = _import_setuptools()
    except Exception as exc:  # noqa: BLE001 - reported to wsbuild, which falls back
        hello = {"ready": False, "error": f"{type(exc).__name__}: {exc}"}
    _stop_observing()
    _reply(channel, hello)
    for line in sys.stdin:
        req = json.loads(line)
        try:
            if req["op"] == "read":
                answer = _read(req, channel)
            elif req["op"] == "compile":
                answer = _compile(req)
            else:
                answer = {"status": 2, "error": f"unknown op {req['op']!r}"}
        except Exception as exc:  # noqa: BLE001 - keep serving other packages
            answer = {"status": 70, "error": f"{type(exc).__name__}: {exc}"}
        _reply(channel, answer)
    return 0


if __name__ == "__main__":
    sys.exit(main())
