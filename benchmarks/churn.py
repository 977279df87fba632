"""Churn: random sequences of changes to every kind of input a package's output depends on, each
followed by an incremental `wsbuild build` and `wsbuild test` in wsbuild's default
configuration (the build cache on, the no-op replay on) and compared with a build and test from
scratch of a fresh copy: `install/` (its files, symlinks and directories, empty ones too, by
content, target and mode) and every test's verdict must be the same. Every step changes
something (a change is drawn as a move away from its input's current variant), and every kind
of change is made in every run (`coverage`). tests/test_churn.py runs 30 random sequences and
the coverage (hypothesis); this script runs more and prints what it found.

    .venv/bin/python benchmarks/churn.py                 # 200 sequences, about an hour
    .venv/bin/python benchmarks/churn.py --sequences 20  # fewer

The workspace copies the patterns of real packages, written here:
- `churn_core` (a CMake package with a package.xml): an outside header (`include_directories`
  of a third-party tree), an outside CMake include, `file(GLOB … CONFIGURE_DEPENDS)` over an
  outside directory installed with `install(FILES …)`, `install(DIRECTORY …)` of an outside
  directory, a generated table whose custom command names its input in a depfile
  (`add_custom_command(DEPFILE …)`), a vendored subdirectory marked COLCON_IGNORE that
  `add_subdirectory` builds, files in directories named `build/` and `log/` it installs, the
  environment variable TURTLEBOT3_MODEL read at configure (turtlebot3's pattern), two values
  from mixins that the defaults file applies (COLCON_DEFAULTS_FILE: `build: {mixin: [...]}`),
  a file outside the package read at configure time only (`file(STRINGS …)`, in no CMake
  list), a header a custom command's shell script writes from the variable CHURN_GEN (a
  variable read by a build step, no build system watches it), and a `tools/` directory it
  installs into its share directory;
- `churn_py` (ament_python, depends on churn_core): its setup.py finds churn_core's share
  directory through ament_index_python and makes a console script of each `*.tool` there (a
  glob over a dependency's share directory), installs a `data_files` file from outside the
  package and one reached through a symlink out of it, reads TURTLEBOT3_MODEL, and takes its
  description from a file outside the package that a subprocess (`cat`) reads; it has a
  Python subpackage `log/`, a test fixture under `test/log/` and tests that read the fixture,
  the environment variables TURTLEBOT3_MODEL and CHURN_TEST_LEVEL (the latter read by a test
  only) and a package of a chained underlay workspace; it is moved inside `src/` and back;
- `churn_under`, the underlay workspace's one ament_python package, which churn_py's tests
  import.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import random
import shutil
import subprocess
import sys
import textwrap
import time
import xml.etree.ElementTree as ElementTree
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
#: a recording run must start this long after the last change it could read (the racy rule)
SETTLE = 1.1
#: the test's own DDS domain (nothing here starts a node, but be safe)
ROS_DOMAIN_ID = "91"
#: variables a sourced workspace or the wheels' bootstrapper set: runs start without them
_SOURCED = ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "COLCON_PREFIX_PATH", "PYTHONPATH",
            "LD_LIBRARY_PATH", "PKG_CONFIG_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE",
            "COLCON_CURRENT_PREFIX", "WSBUILD_CACHE")


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text).lstrip("\n"))


def _package_xml(name: str, build_type: str, depend: Sequence[str] = (),
                 test_depend: Sequence[str] = ()) -> str:
    tags = "".join(f"  <depend>{d}</depend>\n" for d in depend)
    tags += "".join(f"  <test_depend>{d}</test_depend>\n" for d in test_depend)
    return (f'<?xml version="1.0"?>\n<package format="3">\n  <name>{name}</name>\n'
            f"  <version>0.1.0</version>\n  <description>churn test package {name}"
            "</description>\n  <maintainer email=\"churn@example.com\">churn</maintainer>\n"
            f"  <license>Apache-2.0</license>\n{tags}  <export>\n"
            f"    <build_type>{build_type}</build_type>\n  </export>\n</package>\n")


CORE_CMAKELISTS = """
cmake_minimum_required(VERSION 3.16)
project(churn_core CXX)
# reproducible bytes wherever the workspace is (the fresh copy it is compared with is elsewhere)
add_compile_options(-ffile-prefix-map=${CMAKE_CURRENT_SOURCE_DIR}/../..=/churn)
add_link_options(-Wl,--build-id=none)
include(${CMAKE_CURRENT_SOURCE_DIR}/../../cmake/churn_flags.cmake)
if(NOT DEFINED CHURN_MIXIN)
  set(CHURN_MIXIN "none")
endif()
if(NOT DEFINED CHURN_DEFAULT)
  set(CHURN_DEFAULT "none")
endif()
set(CHURN_MODEL "$ENV{TURTLEBOT3_MODEL}")
file(STRINGS ${CMAKE_CURRENT_SOURCE_DIR}/../../shared_data/config.txt CHURN_CONFIG
     LIMIT_COUNT 1)
configure_file(src/config.h.in config.h)
add_custom_command(OUTPUT gen.h
  COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/tools/gen.sh gen.h)
file(GLOB CHURN_GLOBBED CONFIGURE_DEPENDS
     "${CMAKE_CURRENT_SOURCE_DIR}/../../data/globbed/*.txt")
add_custom_command(
  OUTPUT table.h
  COMMAND ${CMAKE_COMMAND} -DOUT=table.h -DDEP=table.d
          -DSRC=${CMAKE_CURRENT_SOURCE_DIR}/../../third_party/table.def
          -P ${CMAKE_CURRENT_SOURCE_DIR}/cmake/gen_table.cmake
  DEPFILE table.d)
add_subdirectory(vendor)
add_executable(churn_core src/main.cpp table.h gen.h)
target_include_directories(churn_core PRIVATE ${CMAKE_CURRENT_BINARY_DIR}
  ${CMAKE_CURRENT_SOURCE_DIR}/../../third_party/include)
target_link_libraries(churn_core vendored)
install(TARGETS churn_core DESTINATION lib/churn_core)
install(FILES ${CHURN_GLOBBED} DESTINATION share/churn_core/globbed)
install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/../../data/shared/
        DESTINATION share/churn_core/shared)
install(DIRECTORY tools/ DESTINATION share/churn_core/tools)
install(FILES build/notes.txt log/changes.txt DESTINATION share/churn_core/docs)
install(FILES package.xml DESTINATION share/churn_core)
install(FILES resource/churn_core DESTINATION share/ament_index/resource_index/packages)
"""

CORE_MAIN = """
#include <cstdio>
#include "config.h"
#include "ext.h"
#include "table.h"
#include "gen.h"
#include "vendor.h"
int vendored();
int main() {{
  std::printf("{greeting} ext=%d table=%d vendor=%d flag=%d mixin=%s default=%s model=%s"
              " config=%s gen=%s\\n", EXT_VALUE, TABLE_VALUE, vendored(), CHURN_FLAG_VALUE,
              CHURN_MIXIN, CHURN_DEFAULT, CHURN_MODEL, CHURN_CONFIG, CHURN_GEN);
  return 0;
}}
"""

PY_SETUP = """
import os
import subprocess
from glob import glob

from ament_index_python.packages import get_package_share_directory
from setuptools import setup

package_name = 'churn_py'
tools_dir = os.path.join(get_package_share_directory('churn_core'), 'tools')
tools = sorted(os.path.splitext(os.path.basename(path))[0]
               for path in glob(os.path.join(tools_dir, '*.tool')))
model = os.environ.get('TURTLEBOT3_MODEL', 'burger')
here = os.path.dirname(os.path.abspath(__file__))
workspace = here.rpartition(os.sep + 'src' + os.sep)[0]
about = subprocess.run(['cat', os.path.join(workspace, 'shared_data', 'about.txt')],
                       capture_output=True, text=True, check=True).stdout.strip()

setup(
    name=package_name,
    version='0.1.0',
    description=about,
    packages=[package_name, package_name + '.log'],
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/models/' + model, ['install/model.yaml']),
        ('share/' + package_name + '/data', ['churn_py/data/link.txt']),
        ('share/' + package_name + '/outside',
         [os.path.join(workspace, 'shared_data', 'outside.yaml')]),
    ],
    zip_safe=True,
    entry_points={'console_scripts': ['churn_py = churn_py.main:main']
                  + [f'{tool} = churn_py.tools:main' for tool in tools]},
)
"""


def write_workspaces(root: Path) -> None:
    """The underlay workspace (`root/under`), the incremental one's sources (`root/ws_a`), the
    mixin and defaults files, all in their base state."""
    under = root / "under" / "src" / "churn_under"
    _write(under / "package.xml", _package_xml("churn_under", "ament_python"))
    _write(under / "setup.py", """
        from setuptools import setup
        setup(name='churn_under', version='0.1.0', packages=['churn_under'],
              data_files=[('share/ament_index/resource_index/packages', ['resource/churn_under']),
                          ('share/churn_under', ['package.xml'])])
        """)
    _write(under / "resource" / "churn_under", "")
    _write(under / "churn_under" / "__init__.py", "")
    ws = root / "ws_a"
    core = ws / "src" / "churn_core"
    _write(core / "package.xml", _package_xml("churn_core", "cmake"))
    _write(core / "CMakeLists.txt", CORE_CMAKELISTS)
    _write(core / "resource" / "churn_core", "")
    _write(core / "src" / "config.h.in", """
        #define CHURN_MIXIN "@CHURN_MIXIN@"
        #define CHURN_DEFAULT "@CHURN_DEFAULT@"
        #define CHURN_MODEL "@CHURN_MODEL@"
        #define CHURN_CONFIG "@CHURN_CONFIG@"
        """)
    _write(core / "tools" / "gen.sh", """
        printf '#define CHURN_GEN "%s"\\n' "${CHURN_GEN:-plain}" > "$1"
        """)
    _write(core / "cmake" / "gen_table.cmake", """
        file(READ "${SRC}" value)
        string(STRIP "${value}" value)
        file(WRITE "${OUT}" "#define TABLE_VALUE ${value}\\n")
        file(WRITE "${DEP}" "table.h: ${SRC}\\n")
        """)
    _write(core / "vendor" / "COLCON_IGNORE", "")
    _write(core / "vendor" / "CMakeLists.txt", """
        add_library(vendored STATIC vendored.cpp)
        target_include_directories(vendored PUBLIC ${CMAKE_CURRENT_SOURCE_DIR})
        """)
    _write(core / "vendor" / "vendored.cpp", '#include "vendor.h"\nint vendored() '
           "{ return VENDOR_VALUE; }\n")
    py = ws / "src" / "churn_py"
    _write(py / "package.xml", _package_xml("churn_py", "ament_python", depend=["churn_core"],
                                            test_depend=["churn_under"]))
    _write(py / "setup.py", PY_SETUP)
    _write(py / "setup.cfg", "[develop]\nscript_dir=$base/lib/churn_py\n"
           "[install]\ninstall_scripts=$base/lib/churn_py\n")
    _write(py / "resource" / "churn_py", "")
    _write(py / "churn_py" / "__init__.py", "")
    _write(py / "churn_py" / "tools.py", "def main():\n    print('a churn tool')\n")
    _write(py / "install" / "model.yaml", "model: churn\n")
    _write(py / "test" / "test_sample.py", """
        from pathlib import Path


        def test_the_sample_log_says_ok():
            text = (Path(__file__).parent / 'log' / 'sample.log').read_text()
            assert 'ok' in text
        """)
    _write(py / "test" / "test_model.py", """
        import os


        def test_the_model_is_not_broken():
            assert os.environ.get('TURTLEBOT3_MODEL', 'burger') != 'broken'
        """)
    _write(py / "test" / "test_level.py", """
        import os


        def test_the_level_is_not_broken():
            assert os.environ.get('CHURN_TEST_LEVEL', '1') != 'broken'
        """)
    _write(py / "test" / "test_underlay.py", """
        from churn_under.core import VALUE


        def test_the_underlay_value_is_small():
            assert VALUE < 3
        """)
    (ws / "shared_data").mkdir(parents=True, exist_ok=True)
    _write(ws / "shared_data" / "outside.yaml", "outside: 1\n")
    (ws / "empty_dirs").mkdir(exist_ok=True)
    for change in CHANGES:
        change.apply(root, 0)


@dataclass(frozen=True)
class Change:
    """One input of the workspace and its variants (variant 0: the base state)."""

    name: str
    variants: int
    apply: Callable[[Path, int], None]
    #: what it changes, for the report
    what: str = ""


def _py_dir(root: Path) -> Path:
    """Where churn_py is now (it is moved inside src/ and back)."""
    src = root / "ws_a" / "src"
    nested = src / "nested" / "churn_py"
    return nested if nested.is_dir() else src / "churn_py"


def _located(root: Path, under: str, rel: str) -> Path:
    """`rel` below `under`, a path of churn_py's where churn_py is now."""
    if under == "ws_a" and rel.startswith("src/churn_py/"):
        return _py_dir(root) / rel[len("src/churn_py/"):]
    return root / under / rel


def _file_variant(rel: str, texts: Sequence[str | None], what: str,
                  under: str = "ws_a") -> Change:
    """A file whose content is one of `texts` (None: the file is absent)."""
    def apply(root: Path, variant: int) -> None:
        path = _located(root, under, rel)
        text = texts[variant]
        if text is None:
            path.unlink(missing_ok=True)
        else:
            _write(path, text)
    return Change(rel, len(texts), apply, what)


def _symlink(root: Path, variant: int) -> None:
    link = _py_dir(root) / "churn_py" / "data" / "link.txt"
    link.parent.mkdir(parents=True, exist_ok=True)
    target = root / "ws_a" / "shared_data" / ("target_a.txt" if variant == 0 else "target_b.txt")
    if link.is_symlink() or link.exists():
        link.unlink()
    link.symlink_to(os.path.relpath(target, link.parent))


def _rename(root: Path, variant: int) -> None:
    directory = _py_dir(root) / "churn_py" / "log"
    names = ("helper.py", "aid.py")
    for name in names:
        (directory / name).unlink(missing_ok=True)
    _write(directory / names[variant], "def help_text():\n    return 'churn'\n")


def _environment(root: Path, variant: int) -> None:
    values = ("", "burger", "waffle", "broken")
    (root / "model").write_text(values[variant])


def _variable(name: str, values: Sequence[str]) -> Change:
    """A variable of the environment wsbuild runs in (`root/variables/<name>`; "" unset)."""
    def apply(root: Path, variant: int) -> None:
        _write(root / "variables" / name, values[variant])
    return Change(f"${name}", len(values), apply, f"the variable {name}")


def _moved(root: Path, variant: int) -> None:
    """churn_py moved inside src/ (its own files, relative, are the same)."""
    src = root / "ws_a" / "src"
    places = (src / "churn_py", src / "nested" / "churn_py")
    current = next((p for p in places if p.exists()), None)
    if current is not None and current != places[variant]:
        link = current / "churn_py" / "data" / "link.txt"
        pointed = os.readlink(link) if link.is_symlink() else ""
        places[variant].parent.mkdir(parents=True, exist_ok=True)
        current.rename(places[variant])
        if pointed:  # a relative link out of the package: its target where it was
            _symlink(root, 1 if pointed.endswith("target_b.txt") else 0)


def _touch(root: Path, variant: int) -> None:
    """A time change without a content change: nothing to rebuild."""
    path = root / "ws_a" / "src" / "churn_core" / "src" / "main.cpp"
    if path.exists() and variant:
        os.utime(path)


def _same_size_backdated(root: Path, variant: int) -> None:
    """A same-size edit with its modification time set back (`cp -p`, `touch -d`)."""
    path = root / "ws_a" / "third_party" / "include" / "ext.h"
    if not path.exists():
        return
    before = path.stat()
    text = path.read_text()
    digit = "7" if variant else "1"
    new = text[:-2] + digit + "\n" if "#define EXT_STAMP" in text else text
    path.write_text(new)
    os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))


CHANGES: tuple[Change, ...] = (
    _file_variant("src/churn_core/src/main.cpp",
                  [CORE_MAIN.format(greeting=g) for g in ("hello", "howdy")],
                  "a source file of the package"),
    _file_variant("src/churn_py/churn_py/main.py",
                  [f"def main():\n    print('{g} from churn_py')\n" for g in ("hello", "howdy")],
                  "a Python module of the package"),
    _file_variant("src/churn_py/churn_py/extra.py", [None, "EXTRA = 1\n"],
                  "a file added to and deleted from a package"),
    Change("src/churn_py/churn_py/log/{helper,aid}.py", 2, _rename,
           "a file renamed in a Python subpackage named log"),
    _file_variant("src/churn_py/churn_py/log/__init__.py", ["", "LEVEL = 2\n"],
                  "a Python subpackage named log"),
    _file_variant("src/churn_py/test/log/sample.log", ["all ok\n", "all bad\n"],
                  "a test fixture under test/log"),
    _file_variant("src/churn_core/build/notes.txt", ["notes 1\n", "notes 2\n"],
                  "an installed file in a directory named build"),
    _file_variant("src/churn_core/log/changes.txt", ["changes 1\n", "changes 2\n"],
                  "an installed file in a directory named log"),
    _file_variant("src/churn_py/install/model.yaml", ["model: churn\n", "model: other\n"],
                  "an installed file in a directory named install"),
    _file_variant("src/churn_core/vendor/vendor.h",
                  [f"#define VENDOR_VALUE {v}\n" for v in (1, 2)],
                  "a header of a vendored subdirectory marked COLCON_IGNORE"),
    _file_variant("third_party/include/ext.h",
                  [f"#define EXT_VALUE {v}\n#define EXT_STAMP 1\n" for v in (1, 2, 3)],
                  "a header outside the package"),
    _file_variant("cmake/churn_flags.cmake",
                  [f"add_compile_definitions(CHURN_FLAG_VALUE={v})\n" for v in (1, 2)],
                  "a CMake file included from outside the package"),
    _file_variant("third_party/table.def", ["10\n", "20\n"],
                  "a generated header's input named only in its depfile"),
    _file_variant("data/globbed/extra.txt", [None, "extra\n"],
                  "a file added to a CONFIGURE_DEPENDS glob's outside directory"),
    _file_variant("data/shared/info.txt", ["info 1\n", "info 2\n", None],
                  "a file of an outside directory that install(DIRECTORY) installs"),
    _file_variant("src/churn_core/tools/beta.tool", [None, "beta\n"],
                  "a file a dependency installs into the share directory setup.py globs"),
    _file_variant("shared_data/outside.yaml", ["outside: 1\n", "outside: 2\n"],
                  "a data_files file outside the Python package"),
    Change("src/churn_py/churn_py/data/link.txt", 2, _symlink, "a symlink retargeted"),
    _file_variant("shared_data/target_a.txt", ["target a\n", "target a, edited\n"],
                  "the file a symlink points to"),
    Change("TURTLEBOT3_MODEL", 4, _environment,
           "an environment variable setup.py, CMakeLists.txt and a test read"),
    _file_variant("colcon_home/mixin/churn.mixin",
                  [json.dumps({"build": {
                      "flavour": {"cmake-args": [f"-DCHURN_MIXIN={v}"]},
                      "extra": {"cmake-args": ["-DCHURN_DEFAULT=two"]}}}) + "\n"
                   for v in ("alpha", "beta")], "a mixin file", under="."),
    _file_variant("defaults.yaml", ["build:\n  mixin: [flavour]\n",
                                    "build:\n  mixin: [flavour, extra]\n"],
                  "the file COLCON_DEFAULTS_FILE names (the mixins it applies)", under="."),
    _file_variant("under/src/churn_under/churn_under/core.py",
                  [f"VALUE = {v}\n" for v in (1, 5)],
                  "a package of the chained underlay workspace (rebuilt)", under="."),
    Change("touch main.cpp", 2, _touch, "a source file touched, its content unchanged"),
    Change("backdated ext.h", 2, _same_size_backdated,
           "a same-size edit of an outside header with its time set back"),
    _file_variant("shared_data/about.txt", ["about one\n", "about two\n"],
                  "a file outside the package a setup.py's subprocess reads"),
    _file_variant("shared_data/config.txt", ["config-1\n", "config-2\n"],
                  "a file outside the package CMake reads at configure time only"),
    _variable("CHURN_GEN", ("", "spicy", "mild")),
    _variable("CHURN_TEST_LEVEL", ("", "2", "broken")),
    Change("move churn_py", 2, _moved, "a package moved inside src/ and back"),
    _file_variant("empty_dirs/.keep", ["", None], "a file outside every package no step reads"),
)
#: changes that also need the base files of the ones that follow (the symlink's targets)
_ALWAYS = ("shared_data/target_b.txt", "target b\n"), ("src/churn_core/tools/alpha.tool",
                                                       "alpha\n")
#: the change that is not an input: the build and install directories removed by hand
CLEAN = "rm -rf build install"


@dataclass
class Churn:
    """One churn run's directories and environment (see the module's docstring)."""

    root: Path
    #: how wsbuild is run
    command: tuple[str, ...] = (sys.executable, "-m", "wsbuild")
    state: dict[str, int] = field(default_factory=dict)
    #: the from-scratch results by state (a state seen again is not built again)
    oracle: dict[str, tuple[dict[str, str], dict[str, str]]] = field(default_factory=dict)
    steps: int = 0
    seconds: dict[str, float] = field(default_factory=lambda: {"incremental": 0.0,
                                                               "scratch": 0.0})

    @property
    def ws(self) -> Path:
        return self.root / "ws_a"

    def setup(self) -> None:
        """The workspaces in their base state, the underlay built, a template of the built
        incremental workspace to start every sequence from."""
        write_workspaces(self.root)
        for rel, text in _ALWAYS:
            _write(self.ws / rel, text)
        self.state = {c.name: 0 for c in CHANGES}
        self._build_underlay()
        self._run("build", cwd=self.ws)
        shutil.copytree(self.ws, self.root / "template", symlinks=True)
        self._snapshot_inputs("base")

    def _snapshot_inputs(self, name: str) -> None:
        """The inputs outside the workspace as the base state has them."""
        for rel in ("colcon_home", "defaults.yaml", "under/src", "model", "variables"):
            source, target = self.root / rel, self.root / f"{name}-inputs" / rel
            if target.exists():
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            if source.is_dir():
                shutil.copytree(source, target, symlinks=True)
            else:
                shutil.copy2(source, target)

    def start_sequence(self) -> None:
        """Back to the base state: the built template copied to the incremental workspace's
        path (a checkout whose build directory is kept), the outside inputs reset."""
        shutil.rmtree(self.ws)
        shutil.copytree(self.root / "template", self.ws, symlinks=True)
        underlay_changed = self.state.get("under/src/churn_under/churn_under/core.py", 0) != 0
        for change in CHANGES:
            if self.state.get(change.name, 0) != 0 and (change.name in (
                    "colcon_home/mixin/churn.mixin", "defaults.yaml", "TURTLEBOT3_MODEL",
                    "under/src/churn_under/churn_under/core.py")
                    or change.name.startswith("$")):
                change.apply(self.root, 0)
        self.state = {c.name: 0 for c in CHANGES}
        if underlay_changed:
            self._build_underlay()

    def environ(self) -> dict[str, str]:
        """A fresh terminal with the underlay workspace sourced, the mixin and defaults files
        in place and TURTLEBOT3_MODEL as the state has it."""
        env = {k: v for k, v in os.environ.items() if k not in _SOURCED}
        under = self.root / "under" / "install"
        for prefix in sorted(under.glob("*/")):
            if (prefix / "share" / "colcon-core").is_dir():
                env["AMENT_PREFIX_PATH"] = os.pathsep.join(
                    p for p in (str(prefix), env.get("AMENT_PREFIX_PATH")) if p)
                site = next(prefix.glob("lib/python3*/site-packages"), None)
                if site is not None:
                    env["PYTHONPATH"] = os.pathsep.join(
                        p for p in (str(site), env.get("PYTHONPATH")) if p)
        env["COLCON_HOME"] = str(self.root / "colcon_home")
        env["COLCON_DEFAULTS_FILE"] = str(self.root / "defaults.yaml")
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        env["ROS_DOMAIN_ID"] = ROS_DOMAIN_ID
        model = (self.root / "model").read_text() if (self.root / "model").exists() else ""
        if model:
            env["TURTLEBOT3_MODEL"] = model
        else:
            env.pop("TURTLEBOT3_MODEL", None)
        variables = self.root / "variables"
        for path in sorted(variables.iterdir()) if variables.is_dir() else []:
            if path.read_text():
                env[path.name] = path.read_text()
            else:
                env.pop(path.name, None)
        return env

    def _run(self, verb: str, *args: str, cwd: Path, env: Mapping[str, str] | None = None,
             check: bool = True) -> subprocess.CompletedProcess[str]:
        done = subprocess.run([*self.command, verb, *args], cwd=cwd,
                              env=dict(env if env is not None else self.environ()),
                              capture_output=True, text=True, timeout=900, check=False)
        if check and done.returncode != 0:
            raise AssertionError(f"wsbuild {verb} in {cwd} exited {done.returncode}:\n"
                                 f"{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
        return done

    def _build_underlay(self) -> None:
        self._run("build", cwd=self.root / "under")

    def change(self, name: str, offset: int) -> int:
        """Apply one change (or CLEAN): the input's variant `offset` away from its current one
        (so every step changes something); the variant it now has."""
        if name == CLEAN:
            for base in ("build", "install"):
                shutil.rmtree(self.ws / base, ignore_errors=True)
            return 0
        change = next(c for c in CHANGES if c.name == name)
        variant = (self.state.get(name, 0) + offset) % change.variants
        change.apply(self.root, variant)
        self.state[name] = variant
        if name.startswith("under/"):
            self._build_underlay()
        return variant

    def compare(self) -> list[str]:
        """An incremental build, a recorded no-op and a test run in the incremental workspace,
        compared with the from-scratch build and test of a fresh copy; what differs."""
        started = time.monotonic()
        env = self.environ()
        built = self._run("build", cwd=self.ws, env=env)
        time.sleep(SETTLE)
        again = self._run("build", cwd=self.ws, env=env)
        tested = self._run("test", cwd=self.ws, env=env, check=False)
        incremental = (tree(self.ws / "install", self.ws), verdicts(self.ws))
        self.seconds["incremental"] += time.monotonic() - started
        scratch = self._scratch(env)
        self.steps += 1
        problems = []
        if "Finished <<<" in again.stdout or "Restored <<<" in again.stdout:
            problems.append("the build after a build was not a no-op:\n" + again.stdout)
        problems += differences("install/", incremental[0], scratch[0])
        problems += differences("test verdicts", incremental[1], scratch[1])
        if problems:
            problems.append(f"incremental build:\n{built.stdout}\ntest:\n{tested.stdout}")
        return problems

    def _scratch(self, env: Mapping[str, str]) -> tuple[dict[str, str], dict[str, str]]:
        """The from-scratch build and test of a fresh copy of the sources (the build cache off:
        it is what the incremental run is held to), memoized by the inputs' contents."""
        key = self._inputs_digest(env)
        if key in self.oracle:
            return self.oracle[key]
        started = time.monotonic()
        fresh = self.root / "ws_b"
        shutil.rmtree(fresh, ignore_errors=True)
        fresh.mkdir()
        for item in self.ws.iterdir():
            if item.name not in ("build", "install", "log"):
                if item.is_dir() and not item.is_symlink():
                    shutil.copytree(item, fresh / item.name, symlinks=True)
                else:
                    shutil.copy2(item, fresh / item.name, follow_symlinks=False)
        scratch_env = {**env, "WSBUILD_CACHE": "off"}
        self._run("build", cwd=fresh, env=scratch_env)
        self._run("test", cwd=fresh, env=scratch_env, check=False)
        result = (tree(fresh / "install", fresh, as_if=self.ws), verdicts(fresh))
        self.oracle[key] = result
        self.seconds["scratch"] += time.monotonic() - started
        return result

    def _inputs_digest(self, env: Mapping[str, str]) -> str:
        """Every input's content: the workspace's sources and outside trees, the mixin and
        defaults files, the underlay's install, TURTLEBOT3_MODEL."""
        digest = hashlib.sha256(json.dumps(
            [env.get(name, "\0unset") for name in ("TURTLEBOT3_MODEL", "CHURN_GEN",
                                                  "CHURN_TEST_LEVEL")]).encode())
        for base in (self.ws, self.root / "colcon_home", self.root / "under" / "install"):
            for path in sorted(base.rglob("*")):
                rel = path.relative_to(base)
                if base == self.ws and rel.parts[0] in ("build", "install", "log"):
                    continue
                if path.is_symlink():
                    digest.update(f"{rel}->{os.readlink(path)}\n".encode())
                elif path.is_file():
                    digest.update(f"{rel}\n".encode() + path.read_bytes())
        digest.update((self.root / "defaults.yaml").read_bytes())
        return digest.hexdigest()


def tree(install: Path, ws: Path, as_if: Path | None = None) -> dict[str, str]:
    """Every file, symlink and directory of `install` (empty ones too) by content digest and
    mode (a symlink by its target), with the workspace's path written as `as_if`'s (the two
    have names of one length)."""
    found: dict[str, str] = {}
    old, new = str(ws).encode(), str(as_if or ws).encode()
    for path in sorted(install.rglob("*")):
        rel = str(path.relative_to(install))
        if path.is_symlink():
            found[rel] = "-> " + os.readlink(path).replace(str(ws), str(as_if or ws))
            continue
        mode = f"{path.stat().st_mode & 0o7777:o}"
        if path.is_dir():
            found[rel + "/"] = f"directory {mode}"
        elif path.is_file():
            data = path.read_bytes().replace(old, new)
            found[rel] = f"{hashlib.sha256(data).hexdigest()} {mode}"
    return found


def verdicts(ws: Path) -> dict[str, str]:
    """Each test case of every JUnit file under build/ with its verdict."""
    found: dict[str, str] = {}
    for path in sorted((ws / "build").rglob("*.xml")):
        try:
            root = ElementTree.parse(path).getroot()
        except (ElementTree.ParseError, OSError):
            continue
        for case in root.iter("testcase"):
            outcome = "passed"
            for child in case:
                if child.tag in ("failure", "error", "skipped"):
                    outcome = child.tag
            found[f"{case.get('classname')}.{case.get('name')}"] = outcome
    return found


def differences(what: str, got: Mapping[str, str], want: Mapping[str, str]) -> list[str]:
    lines = [f"  {name}: {got.get(name, 'missing')} (from scratch: {want.get(name, 'missing')})"
             for name in sorted(set(got) | set(want)) if got.get(name) != want.get(name)]
    return [f"{what} differs from the build from scratch:\n" + "\n".join(lines)] if lines else []


def operations() -> list[tuple[str, int]]:
    """Every change to draw from: each input moved away from its current variant by each
    offset it has (every step changes something), and CLEAN."""
    return [(c.name, offset) for c in CHANGES for offset in range(1, c.variants)] \
        + [(CLEAN, 1)]


def coverage(part: int, parts: int) -> list[tuple[str, int]]:
    """Part `part` of `parts` of a sequence that makes every kind of change once (each part
    also removes build/ and install/ once): over the parts, every input is changed."""
    return [(c.name, 1) for c in CHANGES[part::parts]] + [(CLEAN, 1)]


def run_sequence(churn: Churn, sequence: Sequence[tuple[str, int]]) -> list[str]:
    """Back to the base state, then each change followed by the comparison; what differed,
    naming the changes that led to it."""
    churn.start_sequence()
    done: list[str] = []
    for name, offset in sequence:
        variant = churn.change(name, offset)
        done.append(name if name == CLEAN else f"{name} → variant {variant}")
        problems = churn.compare()
        if problems:
            return [f"after: {'; '.join(done)}", *problems]
    return []


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sequences", type=int, default=200)
    parser.add_argument("--length", type=int, default=4, help="changes per sequence, at most")
    parser.add_argument("--seed", type=int, default=36)
    parser.add_argument("--root", type=Path, default=None)
    args = parser.parse_args(argv)
    import tempfile

    root = args.root or Path(tempfile.mkdtemp(prefix="wsbuild-churn-"))
    churn = Churn(root)
    cache = root / "cache"
    os.environ["WSBUILD_CACHE_DIR"] = str(cache)
    os.environ.pop("WSBUILD_CACHE", None)
    started = time.monotonic()
    churn.setup()
    rng = random.Random(args.seed)
    choices = operations()
    found = 0
    sequences = [coverage(0, 1)] + [
        [rng.choice(choices) for _ in range(rng.randint(1, args.length))]
        for _ in range(args.sequences)]
    for number, sequence in enumerate(sequences):
        problems = run_sequence(churn, sequence)
        if problems:
            found += 1
            print(f"sequence {number}: " + "\n".join(problems), flush=True)
    minutes = (time.monotonic() - started) / 60
    print(f"churn: {args.sequences} sequences, {churn.steps} steps, {len(churn.oracle)} builds "
          f"from scratch ({churn.seconds['scratch'] / 60:.1f} min), incremental "
          f"{churn.seconds['incremental'] / 60:.1f} min, {minutes:.1f} min in all: "
          f"{found} sequences found a difference")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
