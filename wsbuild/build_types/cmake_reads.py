"""What a CMake package's last build read outside the package, from CMake's and the generator's
own lists (cargo's dep-info idea):
- files: the files whose change makes CMake configure again (its regeneration list), the
  libraries and other files build rules name, the headers the compiler read (Ninja's deps
  log, `ninja -t deps`; Make's depfiles), the files custom commands' depfiles name
  (`add_custom_command(DEPFILE …)`: Ninja reads them itself, its deps log lists nothing), the
  files the install script (`cmake_install.cmake`) installs, and the programs the build ran
  (the compilers, CMake, the generator's tool, from CMakeCache.txt);
- listings: the directories `file(GLOB … CONFIGURE_DEPENDS)` searches (CMake's
  `VerifyGlobs.cmake`), and every directory of a directory the install script installs.

These are what `cmake --build` and `cmake --install` (what colcon runs every time) would
notice; recorded in the package's record, a change to any of them makes the plan say "build"."""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Iterator
from pathlib import Path

from wsbuild.build_types import ReadOutside, ninja_deps
from wsbuild.record.configured import read_configured
from wsbuild.build_types.ninja_deps import make_prerequisites
from wsbuild.patterns import lazy

#: CMake's regeneration list in Makefile projects
_MAKEFILE_DEPENDS = lazy(r"set\(CMAKE_MAKEFILE_DEPENDS\s+(.*?)\)", re.DOTALL)


#: the programs of CMakeCache.txt a build runs
_TOOLS = lazy(r"^(CMAKE_(?:C|CXX)_COMPILER|CMAKE_COMMAND|CMAKE_MAKE_PROGRAM|CMAKE_LINKER|"
                    r"CMAKE_AR):[A-Z]+=(/.+)$", re.MULTILINE)
#: a `file(GLOB…)` CMake's VerifyGlobs.cmake checks again before each build
_VERIFY_GLOB = lazy(r"^file\((GLOB|GLOB_RECURSE) NEW_GLOB(.*)\)\s*$", re.MULTILINE)
#: an install script's `file(INSTALL DESTINATION … TYPE X FILES …)` (over several lines when
#: it installs several files)
_FILE_INSTALL = lazy(r"file\(INSTALL DESTINATION (.*?)\)[ \t]*$", re.MULTILINE | re.DOTALL)
#: what ends the list of sources of `file(INSTALL … FILES …)`
_INSTALL_KEYWORDS = frozenset({
    "RENAME", "PERMISSIONS", "FILE_PERMISSIONS", "DIRECTORY_PERMISSIONS", "FILES_MATCHING",
    "PATTERN", "REGEX", "EXCLUDE", "USE_SOURCE_PERMISSIONS", "OPTIONAL", "MESSAGE_NEVER",
    "MESSAGE_LAZY", "MESSAGE_ALWAYS", "NO_SOURCE_PERMISSIONS", "COMPONENTS", "CONFIGURATIONS",
    "FOLLOW_SYMLINK_CHAIN"})


def outside_reads(build_dir: Path, source_dir: Path, ninja: Path | None) -> ReadOutside:
    """What the build in `build_dir` read (absolute paths, normalized, sorted); the caller
    leaves out what lies in the package, its build directory and its stage."""
    files: set[str] = set()
    if (build_dir / "build.ninja").is_file():
        files.update(ninja_deps.build_inputs(build_dir / "build.ninja"))
        files.update(ninja_deps.depfile_inputs(build_dir))
        if ninja is not None:
            files.update(ninja_deps.deps_log(build_dir, ninja))
    else:
        files.update(_makefile_inputs(build_dir))
    files.update(_tools(build_dir))
    files.update(_initial_caches(build_dir))
    listings = set(_verified_globs(build_dir))
    installed, installed_dirs = _installed_sources(build_dir)
    files.update(installed)
    listings.update(installed_dirs)
    return ReadOutside(
        files=tuple(sorted({os.path.normpath(p) for p in files if p.startswith("/")})),
        listings=tuple(sorted({os.path.normpath(p) for p in listings if p.startswith("/")})))


def _tools(build_dir: Path) -> Iterator[str]:
    """The compilers, CMake and the generator's tool the build directory was configured with."""
    try:
        text = (build_dir / "CMakeCache.txt").read_text(errors="replace")
    except OSError:
        return
    for match in _TOOLS.finditer(text):
        yield match.group(2).strip()


def _initial_caches(build_dir: Path) -> Iterator[str]:
    """The scripts the last configure's `-C FILE` arguments preloaded (what it used,
    record/configured.py; CMake's regeneration list does not name them)."""
    configured = read_configured(build_dir)
    args = configured.args if configured is not None else ()
    for index, arg in enumerate(args):
        if arg == "-C" and index + 1 < len(args):
            yield args[index + 1]
        elif arg.startswith("-C") and len(arg) > 2:
            yield arg[2:]


def _verified_globs(build_dir: Path) -> Iterator[str]:
    """The directories `file(GLOB … CONFIGURE_DEPENDS)` searches: each pattern's fixed
    directory, and for GLOB_RECURSE every directory below it."""
    try:
        text = (build_dir / "CMakeFiles" / "VerifyGlobs.cmake").read_text(errors="replace")
    except OSError:
        return
    for match in _VERIFY_GLOB.finditer(text):
        recurse = match.group(1) == "GLOB_RECURSE"
        for pattern in re.findall(r'"((?:[^"\\]|\\.)*)"', match.group(2)):
            if not pattern.startswith("/"):
                continue  # RELATIVE's directory is not a pattern
            yield from _searched(pattern, recurse)


def _searched(pattern: str, recurse: bool) -> Iterator[str]:
    """The directories a glob pattern lists: those its leading directories match."""
    import glob as globbing

    parts = pattern.split("/")
    fixed = next((i for i, part in enumerate(parts) if globbing.has_magic(part)), len(parts) - 1)
    base = "/".join(parts[:fixed]) or "/"
    middle = "/".join(parts[:-1])
    directories = [base] if not globbing.has_magic(middle) else [base, *(
        d for d in globbing.glob(middle) if os.path.isdir(d))]
    if middle != base and not globbing.has_magic(middle):
        directories.append(middle)
    for directory in directories:
        yield directory
        if recurse:
            for sub, _, _ in os.walk(directory, followlinks=True):
                yield sub


def _installed_sources(build_dir: Path) -> tuple[set[str], set[str]]:
    """The files the install scripts (`cmake_install.cmake`, one per directory) install, and
    every directory below a directory they install (whose entries decide what is installed)."""
    files: set[str] = set()
    directories: set[str] = set()
    for script in _install_scripts(build_dir):
        try:
            text = script.read_text(errors="replace")
        except OSError:
            continue
        for match in _FILE_INSTALL.finditer(text):
            arguments = re.findall(r'"((?:[^"\\]|\\.)*)"|(\S+)', match.group(1))
            words = [quoted or bare for quoted, bare in arguments]
            kind = words[words.index("TYPE") + 1] if "TYPE" in words[:-1] else ""
            if "FILES" not in words:
                continue
            sources = []
            for word in words[words.index("FILES") + 1:]:
                if word in _INSTALL_KEYWORDS:
                    break
                sources.append(word)
            for source in sources:
                if not source.startswith("/") or "${" in source:
                    continue
                if kind == "DIRECTORY":
                    for directory, _, names in os.walk(source, followlinks=True):
                        directories.add(directory)
                        files.update(os.path.join(directory, name) for name in names)
                else:
                    files.add(source)
    return files, directories


def _install_scripts(build_dir: Path) -> Iterator[Path]:
    """build/<pkg>/cmake_install.cmake and those of its subdirectories."""
    for directory, names, files in os.walk(build_dir):
        names[:] = [n for n in names if n != "CMakeFiles"]
        if "cmake_install.cmake" in files:
            yield Path(directory, "cmake_install.cmake")


def _makefile_inputs(build_dir: Path) -> Iterator[str]:
    """Makefile projects: CMake's regeneration list, and every prerequisite named in the
    targets' rules and compiler depfiles (`compiler_depend.make`, `*.d`, `depend.make`)."""
    try:
        text = (build_dir / "CMakeFiles" / "Makefile.cmake").read_text(errors="replace")
    except OSError:
        return
    match = _MAKEFILE_DEPENDS.search(text)
    if match:
        for token in re.findall(r'"([^"]*)"', match.group(1)):
            yield token
    for path in _walk_files(build_dir / "CMakeFiles"):
        name = path.name
        if name in ("build.make", "compiler_depend.make", "depend.make") or name.endswith(".d"):
            yield from make_prerequisites(path)


def _walk_files(root: Path) -> Iterable[Path]:
    for directory, _, names in os.walk(root):
        for name in names:
            yield Path(directory, name)
