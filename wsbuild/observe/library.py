"""The observer's two parts as a step loads them: the interposed C library, compiled from
`interposer.c` at first use with the machine's C compiler (the one CMake packages need anyway)
into a private directory of the user's cache (`$XDG_CACHE_HOME/wsbuild-observe`, else
`~/.cache/wsbuild-observe`: beside the build cache, never in it), and the Python hook beside it.
Compiled once per source and compiler: later runs find it by their digest.

Where there is no C compiler, or it fails, nothing is observed: every package is then built
each time (its record says why), never taken for up to date on trust."""

from __future__ import annotations

import os
import shutil
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from wsbuild.files import private_directory, user_cache_dir
from wsbuild.hashes import blake2b

#: the sources, beside this module
SOURCE = Path(__file__).with_name("interposer.c")
HOOK = Path(__file__).with_name("pyhook") / "sitecustomize.py"
#: what the library is called in its directory
LIBRARY = "libwsobserve.so"
#: the compilers tried, in order
COMPILERS = ("cc", "gcc", "clang")
#: seconds the compile of the library may take
_COMPILE_SECONDS = 120

_lock = threading.Lock()
_found: dict[str, Observer | str] = {}


@dataclass(frozen=True, slots=True)
class Observer:
    """The observer's files: the library a step preloads and the directory its Python
    processes find the hook in (alone there, on PYTHONPATH)."""

    library: Path
    hook_dir: Path


def home(environ: Mapping[str, str]) -> Path:
    """Where the observer is compiled: `$XDG_CACHE_HOME/wsbuild-observe`, else
    `~/.cache/wsbuild-observe`."""
    return user_cache_dir(environ, "wsbuild-observe")


def observer(cache_dir: Path, environ: Mapping[str, str]) -> Observer | str:
    """The observer, compiled into `cache_dir/<digest>` when it is not there yet; else why
    there is none (one line). Thread-safe, once per process and directory."""
    key = str(cache_dir)
    with _lock:
        known = _found.get(key)
        if known is None:
            known = _found[key] = _build(cache_dir, environ)
        return known


def _compiler(environ: Mapping[str, str]) -> str | None:
    path = environ.get("PATH", os.defpath)
    for name in COMPILERS:
        found = shutil.which(name, path=path)
        if found:
            return os.path.realpath(found)
    return None


def _build(cache_dir: Path, environ: Mapping[str, str]) -> Observer | str:
    compiler = _compiler(environ)
    if compiler is None:
        return "no C compiler (cc, gcc or clang) to build the step observer with"
    try:
        info = os.stat(compiler)
        digest = blake2b(digest_size=12)
        digest.update(SOURCE.read_bytes())
        digest.update(HOOK.read_bytes())
        digest.update(f"{compiler}\0{info.st_size}\0{info.st_mtime_ns}\0{os.uname().machine}"
                      .encode())
    except OSError as exc:
        return f"cannot read the step observer's sources ({exc.strerror})"
    directory = cache_dir / digest.hexdigest()
    made = Observer(directory / LIBRARY, directory / "pyhook")
    if made.library.is_file() and (made.hook_dir / HOOK.name).is_file():
        return made
    import subprocess  # lazy: off every run that builds nothing

    try:
        private_directory(cache_dir)  # with its parents (a first ~/.cache)
        if os.stat(cache_dir).st_uid != os.getuid():
            return f"{cache_dir} is not the user's own: the step observer is not built there"
        building = Path(f"{directory}.{os.getpid()}.tmp")
        shutil.rmtree(building, ignore_errors=True)
        (building / "pyhook").mkdir(mode=0o700, parents=True)
        done = subprocess.run(
            [compiler, "-shared", "-fPIC", "-O2", "-fno-delete-null-pointer-checks",
             "-o", str(building / LIBRARY), str(SOURCE), "-ldl"],
            capture_output=True, text=True, timeout=_COMPILE_SECONDS, check=False,
            env={"PATH": environ.get("PATH", os.defpath), "LC_ALL": "C"})
        if done.returncode != 0:
            shutil.rmtree(building, ignore_errors=True)
            last = (done.stderr.strip().splitlines() or ["(no output)"])[-1]
            return f"the step observer does not compile with {compiler}: {last}"
        shutil.copyfile(HOOK, building / "pyhook" / HOOK.name)
        os.chmod(building, 0o700)
        try:
            os.rename(building, directory)
        except OSError:  # another wsbuild made it meanwhile
            shutil.rmtree(building, ignore_errors=True)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"cannot build the step observer ({exc})"
    return made
