"""The ament linters on an underlay that lacks some of them: CMake packages for the linters
installed without theirs, stand-ins for the missing ones.

No PyPI wheel provides ament_lint_auto, ament_lint_common or the copyright, lint_cmake and
xmllint linters (the `ros` extra installs the ones that exist: cppcheck, cpplint, flake8,
pep257, uncrustify). The unprefixed `ament-lint-cmake-py` and `ament-pycodestyle`
distributions (0.14.x, also in the `ros` extra) install the programs `ament_lint_cmake` and
`ament_pycodestyle`, whose options are those Jazzy's CMake functions pass, but not those CMake
packages; `ament-mypy` likewise (it needs mypy, which it does not declare).  Upstream packages call them with `BUILD_TESTING` on (directly,
through `ament_lint_auto`, or through rosidl's `ADD_LINTER_TESTS`), and `find_package()`
of a missing one fails the configure.  So wsbuild writes, under the build base (never into
the user's venv):

* `ament_lint_auto` and `ament_lint_common` behaving like upstream's: the first finds the
  package's test dependencies and runs the lint hooks the linters registered, the second
  brings every common linter;
* for a linter in `DRIVEN` whose program is installed but whose CMake package is not, a
  CMake package of that name registering the test Jazzy's registers: the same command line,
  result file, labels and lint hook (so the linter runs for real);
* for each other linter whose CMake package or program is missing, a CMake package of the
  same name whose function (`ament_xmllint()`, ...) and lint hook register no test; they
  leave a mark in the package's build directory, so the build can name them
  (`stand_ins_used`).

A CMake initial-cache script (`-C`) points each stood-in package's `<name>_DIR` at its
stand-in and forgets any earlier choice for the real ones; its name carries a digest of its
content, so a change of what is real reconfigures the packages.  A linter whose wheel is
installed is used as it is.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import UnderlayError
from wsbuild.underlay.repair import write_underlay_file
from wsbuild import inputs
from wsbuild.hashes import sha256

#: Version written into the stand-ins (ament_lint's Jazzy version).
LINT_AUTO_SHIM_VERSION = "0.17.3"

#: the CMake package of each ament linter -> the program its CMake function runs
LINTERS: Mapping[str, str] = {
    "ament_cmake_clang_format": "ament_clang_format",
    "ament_cmake_clang_tidy": "ament_clang_tidy",
    "ament_cmake_copyright": "ament_copyright",
    "ament_cmake_cppcheck": "ament_cppcheck",
    "ament_cmake_cpplint": "ament_cpplint",
    "ament_cmake_flake8": "ament_flake8",
    "ament_cmake_lint_cmake": "ament_lint_cmake",
    "ament_cmake_mypy": "ament_mypy",
    "ament_cmake_pep257": "ament_pep257",
    "ament_cmake_pycodestyle": "ament_pycodestyle",
    "ament_cmake_pyflakes": "ament_pyflakes",
    "ament_cmake_uncrustify": "ament_uncrustify",
    "ament_cmake_xmllint": "ament_xmllint",
}

#: the linters ament_lint_common brings (its package.xml's exec_depends)
COMMON_LINTERS = (
    "ament_cmake_copyright", "ament_cmake_cppcheck", "ament_cmake_cpplint",
    "ament_cmake_flake8", "ament_cmake_lint_cmake", "ament_cmake_pep257",
    "ament_cmake_uncrustify", "ament_cmake_xmllint",
)

@dataclass(frozen=True, slots=True)
class DrivenLinter:
    """What Jazzy's CMake package of a linter registers, for a program installed without it."""

    testname: str
    labels: str
    #: the function's one-value keywords -> the program's option
    options: Mapping[str, str]
    #: the files whose presence makes the lint hook add the test
    globs: tuple[str, ...]


#: linters whose program a PyPI distribution installs without the CMake package
DRIVEN: Mapping[str, DrivenLinter] = {
    "ament_cmake_lint_cmake": DrivenLinter(
        "lint_cmake", "lint_cmake;linter", {"MAX_LINE_LENGTH": "--linelength"},
        ("CMakeLists.txt", "*.cmake")),
    "ament_cmake_mypy": DrivenLinter(
        "mypy", "mypy;linter", {"CONFIG_FILE": "--config"}, ("*.py",)),
    "ament_cmake_pycodestyle": DrivenLinter(
        "pycodestyle", "pep8;pycodestyle;linter", {"MAX_LINE_LENGTH": "--linelength"},
        ("*.py",)),
}

#: where a stood-in linter marks that it was called, relative to the package's build directory
STAND_IN_MARKS = Path("wsbuild_lint_stand_ins")


def find_cmake_package(name: str, prefixes: Iterable[Path],
                       listed: dict[str, frozenset[str]] | None = None) -> Path | None:
    """The directory holding `<name>Config.cmake` / `<name>-config.cmake` in `prefixes`, if any
    (the common ament layouts only, not CMake's full search procedure). Each prefix's `share/`,
    `lib/` and `lib/cmake/` are listed once per `listed` (one lint set-up) and looked at only
    when they hold `name`: a sourced workspace of 1,000 packages puts 1,000 prefixes on the
    search paths, and every linter is looked for in each."""
    listed = {} if listed is None else listed
    for prefix in dict.fromkeys(prefixes):
        base = os.fspath(prefix)
        candidates = []
        if name in _entries(os.path.join(base, "share"), listed):
            candidates += [prefix / "share" / name / "cmake", prefix / "share" / name]
        if name in _entries(os.path.join(base, "lib", "cmake"), listed):
            candidates.append(prefix / "lib" / "cmake" / name)
        if name in _entries(os.path.join(base, "lib"), listed):
            candidates.append(prefix / "lib" / name / "cmake")
        for folder in candidates:
            if inputs.is_file(folder / f"{name}Config.cmake") \
                    or inputs.is_file(folder / f"{name}-config.cmake"):
                return folder
    return None


def _entries(directory: str, listed: dict[str, frozenset[str]]) -> frozenset[str]:
    """The names in `directory` (none when it is missing), listed once per `listed`."""
    found = listed.get(directory)
    if found is None:
        try:
            found = frozenset(inputs.listdir(directory))
        except OSError:
            found = frozenset()
        listed[directory] = found
    return found


@dataclass(frozen=True, slots=True)
class LintSetup:
    """The linters of one build: which are real, which are stood in for, and the CMake
    argument that makes it so."""

    cmake_args: tuple[str, ...]
    #: CMake packages replaced by a stand-in (ament_lint_auto, ament_lint_common, linters)
    stand_ins: tuple[str, ...]
    #: linter CMake packages used as installed
    real: tuple[str, ...]
    #: linter CMake packages wsbuild writes for a program installed without its CMake package
    driven: tuple[str, ...] = ()


def prepare_lint(prefixes: Iterable[Path], path: str, directory: Path, *,
                 write: bool = True) -> LintSetup:
    """Write the stand-ins under `directory` (idempotent) and decide, for each linter, whether
    the real one can run: its CMake package is in `prefixes` and its program on `path`.
    `write=False` (--dry-run) decides the same without writing anything."""
    prefixes = list(dict.fromkeys(prefixes))
    listed: dict[str, frozenset[str]] = {}
    real = tuple(name for name, program in LINTERS.items()
                 if find_cmake_package(name, prefixes, listed) is not None
                 and inputs.which(program, path=path) is not None)
    driven = tuple(name for name in DRIVEN if name not in real
                   and inputs.which(LINTERS[name], path=path) is not None)
    stood_in = [name for name in ("ament_lint_auto", "ament_lint_common")
                if find_cmake_package(name, prefixes, listed) is None]
    stood_in += [name for name in LINTERS if name not in real and name not in driven]
    if write:
        write_lint_auto_shim(directory)
    lines = ["# Generated by wsbuild: which ament linters are stood in for (see wsbuild/underlay/lint.py)"]
    for name in ("ament_lint_auto", "ament_lint_common", *LINTERS):
        if name in driven:
            folder = (directory / "driven" / "share" / name / "cmake").as_posix()
            lines.append(f'set({name}_DIR "{folder}" CACHE PATH "wsbuild, for the program" FORCE)')
        elif name in stood_in:
            folder = (directory / "share" / name / "cmake").as_posix()
            lines.append(f'set({name}_DIR "{folder}" CACHE PATH "wsbuild stand-in" FORCE)')
        else:
            lines.append(f"unset({name}_DIR CACHE)")
    text = "\n".join(lines) + "\n"
    digest = sha256(text.encode()).hexdigest()[:12]
    script = directory / f"lint-{digest}.cmake"
    if write:
        _write(script, text)
    return LintSetup(cmake_args=(f"-C{script}",), stand_ins=tuple(stood_in), real=real,
                     driven=driven)


def stand_ins_used(build_dirs: Iterable[Path]) -> dict[str, list[str]]:
    """Stood-in linter function -> the packages (build directory names) that called it."""
    used: dict[str, list[str]] = {}
    for build_dir in build_dirs:
        try:
            names = sorted(os.listdir(build_dir / STAND_IN_MARKS))
        except OSError:
            continue
        for name in names:
            used.setdefault(name, []).append(build_dir.name)
    return dict(sorted(used.items()))


# --------------------------------------------------------------------------- the CMake files

_VERSION_FILE = """\
# Generated by wsbuild: the stand-in accepts any requested version.
set(PACKAGE_VERSION "{version}")
set(PACKAGE_VERSION_COMPATIBLE TRUE)
set(PACKAGE_VERSION_EXACT FALSE)
"""

#: like every ament package's config: a second find_package() must not register hooks twice
_ONCE = """\
if(_{name}_CONFIG_INCLUDED)
  return()
endif()
set(_{name}_CONFIG_INCLUDED TRUE)
"""

_LINT_AUTO_CONFIG = """\
# Generated by wsbuild: ament_lint_auto as upstream's behaves (no PyPI wheel provides it).
# ament_lint_auto_find_test_dependencies() finds the package's <test_depend>s; at
# ament_package() the lint hooks the found linters registered add their tests.
set(ament_lint_auto_FOUND TRUE)
set(ament_lint_auto_VERSION "{version}")
set(AMENT_LINT_AUTO_IS_WSBUILD_SHIM TRUE)

find_package(ament_cmake_core QUIET REQUIRED)
find_package(ament_cmake_test QUIET REQUIRED)

macro(ament_lint_auto_find_test_dependencies)
  if(NOT "${{ARGN}}" STREQUAL "")
    message(FATAL_ERROR "ament_lint_auto_find_test_dependencies() called with "
      "unused arguments: ${{ARGN}}")
  endif()
  if(NOT _AMENT_PACKAGE_NAME)
    ament_package_xml()
  endif()
  foreach(_wsbuild_lint_dep ${{${{PROJECT_NAME}}_TEST_DEPENDS}})
    if(NOT _wsbuild_lint_dep IN_LIST AMENT_LINT_AUTO_EXCLUDE)
      find_package(${{_wsbuild_lint_dep}} QUIET)
      if(${{_wsbuild_lint_dep}}_FOUND)
        list(APPEND ${{PROJECT_NAME}}_FOUND_TEST_DEPENDS ${{_wsbuild_lint_dep}})
      endif()
    endif()
  endforeach()
  unset(_wsbuild_lint_dep)
endmacro()

ament_register_extension("ament_package" "ament_lint_auto"
  "ament_lint_auto_package_hook.cmake")
"""

_LINT_AUTO_HOOK = """\
# Generated by wsbuild: run the lint hooks of the linters found.
ament_execute_extensions(ament_lint_auto)
"""

_LINT_COMMON_CONFIG = """\
# Generated by wsbuild: ament_lint_common (no PyPI wheel provides it) brings the common
# linters, real where installed, stood in for otherwise. As with upstream's exported
# dependencies, a linter whose <name>_FOUND the package set already (to skip it) is left out.
set(ament_lint_common_FOUND TRUE)
set(ament_lint_common_VERSION "{version}")
foreach(_wsbuild_linter {linters})
  if(NOT ${{_wsbuild_linter}}_FOUND AND NOT _wsbuild_linter IN_LIST AMENT_LINT_AUTO_EXCLUDE)
    find_package(${{_wsbuild_linter}} QUIET REQUIRED)
  endif()
endforeach()
unset(_wsbuild_linter)
"""

_LINTER_CONFIG = """\
# Generated by wsbuild: a stand-in for {package}, whose linter is not installed (no PyPI
# wheel has it). {function}() and its lint hook register no test; they leave a mark in the
# build directory, so that wsbuild names the linter once per build.
set({package}_FOUND TRUE)
set({package}_VERSION "{version}")

function({function})
  file(WRITE "${{CMAKE_BINARY_DIR}}/{marks}/{function}" "")
endfunction()

if(COMMAND ament_register_extension)
  ament_register_extension("ament_lint_auto" "{package}" "{package}_lint_hook.cmake")
endif()
"""

_DRIVEN_CONFIG = """\
# Generated by wsbuild: {package} for the '{program}' program a PyPI distribution installs
# without this CMake package. {function}() registers the test Jazzy's {package} registers.
set({package}_FOUND TRUE)
set({package}_VERSION "{version}")
find_package(ament_cmake_core QUIET REQUIRED)
find_package(ament_cmake_test QUIET REQUIRED)

function({function})
  cmake_parse_arguments(ARG "" "TESTNAME;{keywords}" "" ${{ARGN}})
  if(NOT ARG_TESTNAME)
    set(ARG_TESTNAME "{testname}")
  endif()
  find_program({function}_BIN NAMES "{program}")
  if(NOT {function}_BIN)
    message(FATAL_ERROR "{function}() could not find program '{program}'")
  endif()
  set(_result "${{AMENT_TEST_RESULTS_DIR}}/${{PROJECT_NAME}}/${{ARG_TESTNAME}}.xunit.xml")
  set(_cmd "${{{function}_BIN}}" "--xunit-file" "${{_result}}")
{option_lines}  list(APPEND _cmd ${{ARG_UNPARSED_ARGUMENTS}})
  file(MAKE_DIRECTORY "${{CMAKE_BINARY_DIR}}/{function}")
  ament_add_test("${{ARG_TESTNAME}}"
    COMMAND ${{_cmd}}
    OUTPUT_FILE "${{CMAKE_BINARY_DIR}}/{function}/${{ARG_TESTNAME}}.txt"
    RESULT_FILE "${{_result}}"
    WORKING_DIRECTORY "${{CMAKE_CURRENT_SOURCE_DIR}}")
  set_tests_properties("${{ARG_TESTNAME}}" PROPERTIES LABELS "{labels}")
endfunction()

ament_register_extension("ament_lint_auto" "{package}" "{package}_lint_hook.cmake")
"""

_DRIVEN_OPTION = """\
  if(DEFINED ARG_{keyword})
    list(APPEND _cmd "{option}" "${{ARG_{keyword}}}")
  endif()
"""

_DRIVEN_HOOK = """\
# Generated by wsbuild: {package}'s lint hook.
file(GLOB_RECURSE _wsbuild_lint_files FOLLOW_SYMLINKS {globs})
if(_wsbuild_lint_files)
  message(STATUS "Added test '{testname}' ({program})")
  {function}()
endif()
"""

_LINTER_HOOK = """\
# Generated by wsbuild: what the linter's lint hook would register, stood in for.
{function}()
"""


def _shim_files(directory: Path) -> dict[Path, str]:
    version = LINT_AUTO_SHIM_VERSION
    files: dict[Path, str] = {}

    def package(name: str, config: str, hooks: Mapping[str, str] = {}) -> None:
        folder = directory / "share" / name / "cmake"
        files[folder / f"{name}Config.cmake"] = _ONCE.format(name=name) + config
        files[folder / f"{name}ConfigVersion.cmake"] = _VERSION_FILE.format(version=version)
        for filename, text in hooks.items():
            files[folder / filename] = text

    package("ament_lint_auto", _LINT_AUTO_CONFIG.format(version=version),
            {"ament_lint_auto_package_hook.cmake": _LINT_AUTO_HOOK})
    package("ament_lint_common", _LINT_COMMON_CONFIG.format(
        version=version, linters=" ".join(COMMON_LINTERS)))
    for name, function in LINTERS.items():
        package(name, _LINTER_CONFIG.format(package=name, function=function, version=version,
                                            marks=STAND_IN_MARKS.as_posix()),
                {f"{name}_lint_hook.cmake": _LINTER_HOOK.format(function=function)})
    for name, linter in DRIVEN.items():
        files.update(_driven_files(directory / "driven", name, linter, version))
    return files


def _driven_files(directory: Path, name: str, linter: DrivenLinter,
                  version: str) -> dict[Path, str]:
    program = LINTERS[name]
    folder = directory / "share" / name / "cmake"
    options = "".join(_DRIVEN_OPTION.format(keyword=keyword, option=option)
                      for keyword, option in linter.options.items())
    config = _DRIVEN_CONFIG.format(
        package=name, program=program, function=program, version=version,
        keywords=";".join(linter.options), testname=linter.testname, labels=linter.labels,
        option_lines=options)
    hook = _DRIVEN_HOOK.format(package=name, program=program, function=program,
                               testname=linter.testname,
                               globs=" ".join(f'"{glob}"' for glob in linter.globs))
    return {
        folder / f"{name}Config.cmake": _ONCE.format(name=name) + config,
        folder / f"{name}ConfigVersion.cmake": _VERSION_FILE.format(version=version),
        folder / f"{name}_lint_hook.cmake": hook,
    }


def write_lint_auto_shim(directory: Path) -> Path:
    """Write the stand-ins (ament_lint_auto, ament_lint_common, one per linter) under
    `directory` (idempotent); return that prefix. `prepare_lint` decides which are used."""
    for path, text in _shim_files(directory).items():
        _write(path, text)
    return directory


def _write(path: Path, text: str) -> None:
    try:
        if not inputs.is_file(path) or inputs.read_text(path) != text:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_underlay_file(path, text)
    except OSError as exc:
        raise UnderlayError(f"cannot write the ament linter stand-ins: {exc}", path=path) from exc
