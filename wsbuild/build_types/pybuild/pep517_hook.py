"""Call a PEP 517 backend's build_wheel in the current directory: run by the target interpreter.

usage: python pep517_hook.py BACKEND WHEEL_DIR [--backend-path DIR]... [--requires REQ]...
                             [--no-setup-requires]

Like `python -m build --no-isolation`, the backend and the build requirements must already be
installed; a missing one is reported by name before the backend runs. Prints the built
wheel's file name as the last line. This file must not import wsbuild (the target
interpreter may not have it) and must keep working on Python 3.10.
"""

from __future__ import annotations

import sys

# `python pep517_hook.py` puts the wsbuild package directory first on sys.path; the backend
# must not be able to import wsbuild's modules by accident.
del sys.path[0]

import importlib  # noqa: E402
import importlib.metadata  # noqa: E402
import importlib.util  # noqa: E402
import os  # noqa: E402
import re  # noqa: E402

from wsbuild.patterns import lazy

_NAME = lazy(r"^\s*([A-Za-z0-9](?:[A-Za-z0-9._-]*[A-Za-z0-9])?)")


def _fail(message: str) -> None:
    sys.stderr.write(f"error: {message}\n")
    raise SystemExit(1)


def _requirement_class():
    for module in ("packaging.requirements", "setuptools.extern.packaging.requirements",
                   "setuptools._vendor.packaging.requirements"):
        try:
            return importlib.import_module(module).Requirement
        except ImportError:
            continue
    return None


def _missing(requirements: list) -> list:
    """Names of requirements (whose markers apply) with no installed distribution."""
    requirement_class = _requirement_class()
    missing = []
    for text in requirements:
        if requirement_class is not None:
            try:
                requirement = requirement_class(text)
            except Exception:  # noqa: BLE001 - an unparsable requirement is the backend's problem
                continue
            if requirement.marker is not None and not requirement.marker.evaluate():
                continue
            name = requirement.name
        else:
            if ";" in text:
                continue  # cannot evaluate the marker without packaging
            match = _NAME.match(text)
            if not match:
                continue
            name = match.group(1)
        try:
            importlib.metadata.distribution(name)
        except importlib.metadata.PackageNotFoundError:
            missing.append(name)
    return missing


def _load_backend(spec: str, backend_path: list):
    if backend_path:
        # PEP 517: in-tree backends are importable from these source-relative directories
        sys.path[:0] = [os.path.abspath(p) for p in backend_path]
    module_name, _, attribute = spec.partition(":")
    try:
        backend = importlib.import_module(module_name)
    except ImportError as exc:
        _fail(f"build backend {spec!r} is not importable by {sys.executable}: {exc} "
              f"(install it: {sys.executable} -m pip install <its distribution>)")
    for part in filter(None, attribute.split(".")):
        backend = getattr(backend, part)
    return backend


def _parse(argv: list) -> tuple:
    positional, backend_path, requires, skip_requires_hook = [], [], [], False
    args = iter(argv)
    for arg in args:
        if arg == "--backend-path":
            backend_path.append(next(args))
        elif arg == "--requires":
            requires.append(next(args))
        elif arg == "--no-setup-requires":
            skip_requires_hook = True
        else:
            positional.append(arg)
    if len(positional) != 2:
        sys.stderr.write(__doc__ or "")
        raise SystemExit(2)
    return positional[0], positional[1], backend_path, requires, skip_requires_hook


def main(argv: list) -> int:
    spec, wheel_dir, backend_path, requires, skip_requires_hook = _parse(argv)
    missing = _missing(requires)
    if missing:
        _fail(f"building this package needs {', '.join(missing)}, not installed for "
              f"{sys.executable} (install: {sys.executable} -m pip install {' '.join(missing)})")
    backend = _load_backend(spec, backend_path)
    get_requires = getattr(backend, "get_requires_for_build_wheel", None)
    if skip_requires_hook and spec.startswith("setuptools.build_meta"):
        # wsbuild knows there are no setup_requires, so the hook (another full setup.py run)
        # could only add `wheel`, which setuptools before 70.1 needs for bdist_wheel
        found = importlib.util.find_spec("setuptools.command.bdist_wheel") is not None
        needed = [] if found else ["wheel"]
    else:
        needed = list(get_requires({})) if get_requires is not None else []
    missing = _missing(needed)
    if missing:
        _fail(f"the build backend {spec} needs {', '.join(missing)}, not installed for "
              f"{sys.executable} (install: {sys.executable} -m pip install {' '.join(missing)})")
    name = backend.build_wheel(os.path.abspath(wheel_dir), {}, None)
    sys.stdout.write(f"{name}\n")
    return 0


def _setup_py_line(exc: BaseException) -> str:
    """setuptools runs setup.py from a string (`File "<string>", line 23`): the line naming
    setup.py and that line, as for a syntax error ("" when the error was not raised there)."""
    where = ""
    tb = exc.__traceback__
    while tb is not None:
        frame = tb.tb_frame
        script = frame.f_globals.get("__file__") or ""
        if frame.f_code.co_filename == "<string>" and str(script).endswith("setup.py"):
            where = f"{script}:{tb.tb_lineno}"
        tb = tb.tb_next
    return f"{where}: {type(exc).__name__}: {exc}" if where else ""


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except Exception as error:  # the traceback as Python prints it, then where in setup.py
        import traceback

        traceback.print_exc()
        line = _setup_py_line(error)
        if line:
            sys.stderr.write(line + "\n")
        sys.exit(1)
