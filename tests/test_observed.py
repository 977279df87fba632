"""Observed, not declared (issue 42): a package's record holds what its steps were observed to
read (observe/, record/observed.py), so every change below, made after a recorded build in the
default configuration (the local build cache on, the no-op replay on), rebuilds or reruns what
it must, and nothing else; the install then equals a build from scratch. Each case was wrong
before the steps were observed ("up to date", "cut off", "restored" or "cached: passed" over a
stale result, or every package rebuilt for a variable no step read). Every build here runs its
steps under the build-step oracle (builder/oracles/step_trace.py), which holds the observed record to
what strace saw."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest

from test_build_helpers import clean_env, output, write, write_ament_python, write_cmake
from test_build_helpers import wsbuild as run

pytestmark = pytest.mark.usefixtures("traced_steps")

#: git's identity for the commits of the tests' repositories
GIT = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.com", "GIT_COMMITTER_NAME": "t",
       "GIT_COMMITTER_EMAIL": "t@example.com", "GIT_CONFIG_GLOBAL": "/dev/null",
       "GIT_CONFIG_NOSYSTEM": "1"}


def _build(ws: Path, *args: str, env: dict[str, str] | None = None
           ) -> subprocess.CompletedProcess[str]:
    result = run("build", *args, cwd=ws, env=env or clean_env())
    assert result.returncode == 0, output(result)
    assert "Traceback" not in result.stdout + result.stderr, output(result)
    return result


def _finished(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith(("Finished <<<", "Restored <<<")))


def _restored(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith("Restored <<<"))


def _settled(ws: Path, env: dict[str, str] | None = None) -> None:
    """Built, and a second build that builds nothing (its record is what the next one
    compares with)."""
    _build(ws, env=env)
    time.sleep(1.1)  # the racy rule: a change in the second of a recording is not trusted
    again = _build(ws, env=env)
    assert _finished(again) == [], output(again)


def _program(ws: Path, pkg: str, *, env: dict[str, str] | None = None) -> str:
    done = subprocess.run([str(ws / "install" / pkg / "bin" / pkg)], capture_output=True,
                          text=True, timeout=30, check=True, env=env)
    return done.stdout.strip()


def _cmake_program(src: Path, name: str, prelude: str, source: str,
                   files: dict[str, str] | None = None, project: str = "CXX",
                   after: str = "") -> Path:
    return write_cmake(src, name, f"""
        cmake_minimum_required(VERSION 3.16)
        project({name} {project})
        {prelude}
        add_executable({name} src/main.cpp)
        target_include_directories({name} PRIVATE ${{CMAKE_CURRENT_BINARY_DIR}})
        {after}
        install(TARGETS {name} DESTINATION bin)
        install(FILES package.xml DESTINATION share/{name})
        """, files={"src/main.cpp": source, **(files or {})})


def _git(cwd: Path, *args: str) -> None:
    subprocess.run(["git", *args], cwd=cwd, env={**clean_env(), **GIT}, check=True,
                   capture_output=True, timeout=60)


PRINT_MACRO = '#include <cstdio>\n#include "{header}"\nint main() {{ std::puts({macro}); }}\n'


def _from_scratch(ws: Path, tmp_path: Path, env: dict[str, str] | None = None) -> Path:
    """A fresh copy of the workspace's sources, built from scratch with the cache off."""
    fresh = tmp_path / f"fresh-{time.monotonic_ns()}" / "ws"
    shutil.copytree(ws / "src", fresh / "src", symlinks=True)
    for extra in ws.iterdir():  # what lies beside src/ (the shared files of the tests)
        if extra.name not in ("src", "build", "install", "log"):
            shutil.copytree(extra, fresh / extra.name, symlinks=True) if extra.is_dir() \
                else shutil.copy2(extra, fresh / extra.name)
    _build(fresh, "--no-cache", env=env)
    return fresh


# ---------------------------------------------------------------- steps that always run


def test_an_always_run_target_that_reads_git_is_built_again_after_a_new_tag(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    pkg = _cmake_program(ws / "src", "tagged", "", PRINT_MACRO.format(
        header="version.h", macro="VERSION"), after="""
        add_custom_target(version_header ALL
            COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/version.sh ${CMAKE_CURRENT_BINARY_DIR}/version.h
            BYPRODUCTS ${CMAKE_CURRENT_BINARY_DIR}/version.h)
        add_dependencies(tagged version_header)
        """, files={"version.sh": 'v=$(git -C "$(dirname "$0")" describe --tags)\n'
                                  'printf \'#define VERSION "%s"\\n\' "$v" > "$1.new"\n'
                                  'mv "$1.new" "$1"\n'})
    _git(pkg, "init", "-q")
    _git(pkg, "add", "CMakeLists.txt", "package.xml", "src", "version.sh")
    _git(pkg, "commit", "-qm", "one")
    _git(pkg, "tag", "v1")
    # the build cache on, in a directory of its own (WSBUILD_CACHE empty: local only)
    env = clean_env(**GIT, XDG_CACHE_HOME=str(tmp_path / "xdg"), WSBUILD_CACHE="")
    env.pop("WSBUILD_CACHE_DIR", None)
    _build(ws, env=env)
    assert _program(ws, "tagged") == "v1"
    # its build system always has work: the package is built every time (volatile)
    record = json.loads((ws / "build" / "tagged" / ".wsbuild" / "record.json").read_text())
    assert "version.sh" in record["volatile"], record["volatile"]
    # and the cache keeps no entry of it, which could never be restored (its log says why)
    log = (ws / "log" / "latest_build" / "tagged" / "command.log").read_text()
    assert "not cached: its build system always has work" in log, log
    stats = run("cache", "stats", cwd=ws, env=env)
    assert "0 entries, 0 blobs" in stats.stdout, output(stats)
    again = _build(ws, env=env)
    assert _finished(again) == ["tagged"], output(again)
    _git(pkg, "commit", "-q", "--allow-empty", "-m", "two")
    _git(pkg, "tag", "v2")
    result = _build(ws, env=env)
    assert _finished(result) == ["tagged"], output(result)
    assert _program(ws, "tagged") == "v2"


def test_an_install_script_outside_the_package_is_read_by_the_install(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    script = write(ws / "shared" / "extra.cmake",
                   'file(WRITE "${CMAKE_INSTALL_PREFIX}/share/scripted/extra.txt" "one")\n')
    write_cmake(ws / "src", "scripted", f"""
        cmake_minimum_required(VERSION 3.16)
        project(scripted NONE)
        install(SCRIPT "{script}")
        install(FILES package.xml DESTINATION share/scripted)
        """)
    _settled(ws)
    script.write_text(script.read_text().replace('"one"', '"two"'))
    result = _build(ws)
    assert _finished(result) == ["scripted"], output(result)
    assert (ws / "install" / "scripted" / "share" / "scripted" / "extra.txt").read_text() == "two"


# --------------------------------------------------------------- what a setup.py reads


def _setup_py(pkg: Path, prelude: str, version: str) -> None:
    """The package's setup.py with `prelude` before setup() and `version` as its version."""
    text = (pkg / "setup.py").read_text()
    header = "from setuptools import find_packages, setup"
    assert header in text
    text = text.replace(header, f"{header}\n{prelude}")
    text = text.replace("version='0.1.0'", f"version={version}")
    (pkg / "setup.py").write_text(text)


def _version(ws: Path, pkg: str) -> str:
    infos = sorted((ws / "install" / pkg / "lib").rglob("*.egg-info"))
    assert len(infos) == 1, infos
    return infos[0].name.split("-")[1]


def test_a_setup_py_that_versions_itself_with_git_describe_is_built_after_a_new_tag(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    pkg = write_ament_python(ws / "src", "gitver", modules={"main.py": "def main():\n    pass\n"})
    _setup_py(pkg, "import subprocess\nVERSION = subprocess.run(['git', 'describe', '--tags'], "
                   "capture_output=True, text=True).stdout.strip().lstrip('v')",
              "VERSION")
    _git(pkg, "init", "-q")
    _git(pkg, "add", ".")
    _git(pkg, "commit", "-qm", "one")
    _git(pkg, "tag", "v1.0.0")
    _settled(ws, env=clean_env(**GIT))
    assert _version(ws, "gitver") == "1.0.0"
    _git(pkg, "commit", "-q", "--allow-empty", "-m", "two")
    _git(pkg, "tag", "v1.1.0")
    result = _build(ws, env=clean_env(**GIT))
    assert _finished(result) == ["gitver"], output(result)
    assert _version(ws, "gitver") == "1.1.0"


def test_a_helper_module_a_setup_py_imports_from_outside_the_package_is_held_by_its_source(
        tmp_path: Path) -> None:
    """Python reads the compiled .pyc of a module whose source it found unchanged: the record
    holds the source, so every edit of it is seen, not only the first."""
    ws = tmp_path / "ws"
    helper = write(ws / "shared" / "versioning.py", "VERSION = '1.0.0'\n")
    pkg = write_ament_python(ws / "src", "helped", modules={"main.py": "def main():\n    pass\n"})
    _setup_py(pkg, f"import sys\nsys.path.insert(0, {str(helper.parent)!r})\n"
                   "import versioning", "versioning.VERSION")
    # Python writes bytecode, as on most users' machines: reading setup.py writes none beside
    # the helper (a new __pycache__ there would build the package once more)
    env = {k: v for k, v in clean_env().items() if k != "PYTHONDONTWRITEBYTECODE"}
    _settled(ws, env=env)
    for version in ("1.1.0", "1.2.0"):
        helper.write_text(f"VERSION = '{version}'\n")
        result = _build(ws, env=env)
        assert _finished(result) == ["helped"], output(result)
        assert _version(ws, "helped") == version


def test_a_setup_py_with_its_own_cmdclass_is_observed_through_its_wheel_build(
        tmp_path: Path) -> None:
    """Its own cmdclass takes the PEP 517 fallback (pip builds a wheel in processes of its
    own): they are observed too, and the package is not taken for up to date."""
    ws = tmp_path / "ws"
    stamp = write(ws / "shared" / "stamp.txt", "one\n")
    pkg = write_ament_python(ws / "src", "custom", modules={"main.py": "def main():\n    pass\n"})
    _setup_py(pkg, "from setuptools.command.build_py import build_py\n"
                   "class Stamped(build_py):\n"
                   "    def run(self):\n"
                   "        super().run()\n"
                   f"STAMP = open({str(stamp)!r}).read().strip()",
              "'1.0.0', cmdclass={'build_py': Stamped}")
    setup = pkg / "setup.py"
    setup.write_text(setup.read_text().replace("description='Test package'", "description=STAMP"))
    _settled(ws)
    record = json.loads((ws / "build" / "custom" / ".wsbuild" / "record.json").read_text())
    assert record["complete"], record["unobserved"]
    assert str(stamp) in record["outside"]["files"]
    stamp.write_text("two\n")
    result = _build(ws)
    assert _finished(result) == ["custom"], output(result)
    info = next((ws / "install" / "custom" / "lib").rglob("PKG-INFO"))
    assert "Summary: two" in info.read_text()


# ------------------------------------------------------------ what CMake reads at configure


def test_a_file_cmake_reads_at_configure_time_rebuilds_and_is_never_restored_stale(
        tmp_path: Path) -> None:
    """The file is named by a path up out of the package (`../../shared/greeting.txt`), as
    turtlebot3's and churn's are: the `..` is the kernel's, not a file of the package's."""
    ws = tmp_path / "ws"
    config = write(ws / "shared" / "greeting.txt", "one\n")
    _cmake_program(ws / "src", "configured", """
        file(STRINGS "${CMAKE_CURRENT_SOURCE_DIR}/../../shared/greeting.txt" GREETING
             LIMIT_COUNT 1)
        add_compile_definitions(GREETING="${GREETING}")
        """, '#include <cstdio>\nint main() { std::puts(GREETING); }\n')
    _settled(ws)
    config.write_text("two\n")
    result = _build(ws)
    assert _finished(result) == ["configured"], output(result)
    assert _program(ws, "configured") == "two"
    # a fresh checkout: the entry built from "one" is never restored for "three"
    config.write_text("three\n")
    for base in ("build", "install"):
        shutil.rmtree(ws / base)
    fresh = _build(ws)
    assert _restored(fresh) == [], output(fresh)
    assert _program(ws, "configured") == "three"


def test_a_file_of_the_packages_own_read_at_configure_time_configures_again(
        tmp_path: Path) -> None:
    """version.txt in the package, read by file(READ): CMake does not watch it, so its edit
    has the package configured again (a build alone printed the old version)."""
    ws = tmp_path / "ws"
    pkg = _cmake_program(ws / "src", "versioned", """
        file(READ ${CMAKE_CURRENT_SOURCE_DIR}/version.txt VERSION_TEXT)
        string(STRIP "${VERSION_TEXT}" VERSION_TEXT)
        add_compile_definitions(VERSION_TEXT="${VERSION_TEXT}")
        """, '#include <cstdio>\nint main() { std::puts(VERSION_TEXT); }\n',
                         files={"version.txt": "1.0\n"})
    _settled(ws)
    write(pkg / "version.txt", "1.1\n")
    result = _build(ws)
    assert _finished(result) == ["versioned"], output(result)
    assert _program(ws, "versioned") == "1.1", output(result)
    assert _finished(_build(ws)) == []


def test_a_header_that_appears_where_find_path_looked_first_is_found(tmp_path: Path) -> None:
    """find_path() looked in `first` (nothing there) and found answer.h in `second`; CMake
    keeps that in its cache and never looks again. When answer.h appears in `first`, the
    package is configured from a fresh cache and compiles the new header, as a build from
    scratch does; the next build is a no-op."""
    ws = tmp_path / "ws"
    first, second = ws / "vendor" / "first", ws / "vendor" / "second"
    first.mkdir(parents=True)
    write(second / "answer.h", '#define ANSWER "second"\n')
    _cmake_program(ws / "src", "found", f"""
        find_path(ANSWER_DIR answer.h PATHS {first} {second} NO_DEFAULT_PATH)
        include_directories(${{ANSWER_DIR}})
        """, PRINT_MACRO.format(header="answer.h", macro="ANSWER"))
    _settled(ws)
    write(first / "answer.h", '#define ANSWER "first"\n')
    result = _build(ws)
    assert _finished(result) == ["found"], output(result)
    assert _program(ws, "found") == "first" == _program(_from_scratch(ws, tmp_path), "found")
    time.sleep(1.1)
    assert _finished(_build(ws)) == []


def test_a_variable_the_configure_stopped_reading_costs_no_rebuild(tmp_path: Path) -> None:
    """mode.txt decides whether the configure reads $FLAVOR; after it says `fixed`, the
    package is configured again from a fresh cache and no longer reads the variable, so a
    change of FLAVOR builds nothing (the earlier configure's reads went with its cache)."""
    ws = tmp_path / "ws"
    pkg = _cmake_program(ws / "src", "moded", """
        file(STRINGS ${CMAKE_CURRENT_SOURCE_DIR}/mode.txt MODE)
        if(MODE STREQUAL "env")
          set(TASTE "$ENV{FLAVOR}")
        else()
          set(TASTE "fixed")
        endif()
        add_compile_definitions(TASTE="${TASTE}")
        """, '#include <cstdio>\nint main() { std::puts(TASTE); }\n',
                         files={"mode.txt": "env\n"})
    _settled(ws, env=clean_env(FLAVOR="salty"))
    write(pkg / "mode.txt", "fixed\n")
    assert _finished(_build(ws, env=clean_env(FLAVOR="salty"))) == ["moded"]
    assert _program(ws, "moded") == "fixed"
    time.sleep(1.1)
    result = _build(ws, env=clean_env(FLAVOR="sour"))
    assert _finished(result) == [], output(result)


def test_a_glob_with_a_wildcard_in_a_directory_sees_a_new_directory(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    robots = ws / "robots"
    write(robots / "a" / "config" / "a.yaml", "a: 1\n")
    write_cmake(ws / "src", "fleet", f"""
        cmake_minimum_required(VERSION 3.16)
        project(fleet NONE)
        file(GLOB configs CONFIGURE_DEPENDS "{robots}/*/config/*.yaml")
        install(FILES ${{configs}} DESTINATION share/fleet)
        install(FILES package.xml DESTINATION share/fleet)
        """)
    _settled(ws)
    write(robots / "b" / "config" / "b.yaml", "b: 2\n")
    result = _build(ws)
    assert _finished(result) == ["fleet"], output(result)
    assert sorted(p.name for p in (ws / "install" / "fleet" / "share" / "fleet").glob("*.yaml")) \
        == ["a.yaml", "b.yaml"]


# ---------------------------------------------------------------------- the environment


def test_a_variable_is_an_input_where_a_step_read_it_whatever_its_name(tmp_path: Path) -> None:
    """BUILD_NUMBER read by a setup.py, a variable read by $ENV{} at configure, one read by a
    C program a custom command runs: each rebuilds its reader only. A variable pointing into
    install/ counts by its value. Variables no step reads (an editor's, a terminal's, the
    locale, any name) build nothing."""
    ws = tmp_path / "ws"
    src = ws / "src"
    stamped = write_ament_python(src, "stamped", modules={"main.py": "def main():\n    pass\n"})
    _setup_py(stamped, "import os", "'1.0.' + os.environ.get('BUILD_NUMBER', '0')")
    mapped = write_ament_python(src, "mapped", modules={"main.py": "def main():\n    pass\n"})
    _setup_py(mapped, "import os", "'2.0.' + str(len(os.environ.get('MAP_FILE', '')))")
    _cmake_program(src, "flavored", 'add_compile_definitions(FLAVOR="$ENV{FLAVOR}")',
                   '#include <cstdio>\nint main() { std::puts(FLAVOR); }\n')
    _cmake_program(src, "generated", "", PRINT_MACRO.format(header="gen.h", macro="GENERATED"),
                   project="C CXX", after="""
        add_executable(gen src/gen.c)
        add_custom_command(OUTPUT gen.h COMMAND gen > gen.h DEPENDS gen)
        target_sources(generated PRIVATE ${CMAKE_CURRENT_BINARY_DIR}/gen.h)
        """,
                   files={"src/gen.c": '#include <stdio.h>\n#include <stdlib.h>\nint main(void) '
                                       '{ const char *v = getenv("GEN_FLAVOR"); printf("#define '
                                       'GENERATED \\"%s\\"\\n", v ? v : "none"); return 0; }\n'})
    base = {"BUILD_NUMBER": "7", "FLAVOR": "salty", "GEN_FLAVOR": "sweet",
            "MAP_FILE": str(ws / "install" / "a.yaml")}
    _settled(ws, env=clean_env(**base))
    quiet = _build(ws, env=clean_env(**base, EDITOR="vim", PAGER="less", LANG="de_DE.UTF-8",
                                     GNOME_TERMINAL_SCREEN="/org/gnome/Terminal/screen/1",
                                     VSCODE_GIT_IPC_HANDLE="/run/user/1/vscode-git.sock",
                                     ONLY="w2", TERM="xterm-kitty"))
    assert _finished(quiet) == [], output(quiet)
    for changed, reader in (({"BUILD_NUMBER": "8"}, "stamped"), ({"FLAVOR": "sour"}, "flavored"),
                            ({"GEN_FLAVOR": "bitter"}, "generated"),
                            ({"MAP_FILE": str(ws / "install" / "bb.yaml")}, "mapped")):
        base.update(changed)
        result = _build(ws, env=clean_env(**base))
        assert _finished(result) == [reader], (changed, output(result))
    assert _version(ws, "stamped") == "1.0.8"
    assert _program(ws, "flavored") == "sour" and _program(ws, "generated") == "bitter"
    assert _version(ws, "mapped") == f"2.0.{len(base['MAP_FILE'])}"
    # the user says a variable reaches no build (--env-ignore): its change builds nothing
    base["BUILD_NUMBER"] = "9"
    ignored = _build(ws, "--env-ignore", "BUILD_NUMBER", env=clean_env(**base))
    assert _finished(ignored) == [], output(ignored)


def test_a_variable_read_when_the_build_step_configures_again_configures_again(
        tmp_path: Path) -> None:
    """A CMakeLists.txt that reads $ENV{FLAVOR} and a file CMake watches (configure_file):
    after an edit of that file the build step itself runs CMake's configure again (reading
    the variable as the build step's); a later change of the variable alone still configures
    again, and the program says the new value (churn found it printing the old one)."""
    ws = tmp_path / "ws"
    _cmake_program(ws / "src", "tasted", 'add_compile_definitions(FLAVOR="$ENV{FLAVOR}")\n'
                   "configure_file(version.h.in version.h)",
                   '#include <cstdio>\n#include "version.h"\n'
                   'int main() { std::printf("%s %s\\n", FLAVOR, VERSION); }\n',
                   files={"version.h.in": '#define VERSION "1"\n'})
    _settled(ws, env=clean_env(FLAVOR="salty"))
    write(ws / "src" / "tasted" / "version.h.in", '#define VERSION "2"\n')
    assert _finished(_build(ws, env=clean_env(FLAVOR="salty"))) == ["tasted"]
    assert _program(ws, "tasted") == "salty 2"
    time.sleep(1.1)
    result = _build(ws, env=clean_env(FLAVOR="sour"))
    assert _finished(result) == ["tasted"], output(result)
    assert _program(ws, "tasted") == "sour 2", output(result)


def test_a_variable_a_dependencys_hook_sets_is_read_by_its_dependent_as_it_is_now(
        tmp_path: Path) -> None:
    """The dependent's setup.py reads a variable its dependency's environment hook sets: when
    the hook changes, the dependent is built again, not cut off with the old value."""
    ws = tmp_path / "ws"
    src = ws / "src"
    hook = write(src / "flavor_hook" / "env-hooks" / "flavor.dsv.in", "set;WSB_FLAVOR;sweet\n")
    write_cmake(src, "flavor_hook", """
        cmake_minimum_required(VERSION 3.16)
        project(flavor_hook NONE)
        find_package(ament_cmake REQUIRED)
        ament_environment_hooks("${CMAKE_CURRENT_SOURCE_DIR}/env-hooks/flavor.dsv.in")
        ament_package()
        """, build_type="ament_cmake", buildtool=["ament_cmake"])
    user = write_ament_python(src, "flavor_user", modules={"main.py": "def main():\n    pass\n"},
                              depend=["flavor_hook"])
    _setup_py(user, "import os", "'1.0.' + str(len(os.environ.get('WSB_FLAVOR', '')))")
    _settled(ws)
    assert _version(ws, "flavor_user") == "1.0.5"
    hook.write_text("set;WSB_FLAVOR;bittersweet\n")
    result = _build(ws)
    assert _finished(result) == ["flavor_hook", "flavor_user"], output(result)
    assert _version(ws, "flavor_user") == "1.0.11"


def test_a_binary_that_read_home_is_never_restored_for_another_home(tmp_path: Path) -> None:
    """Two users of one checkout path and one build cache: the package whose build read HOME
    is built for the other user (and each finds their own entry again); the one whose build
    read nothing that differs between them is restored."""
    ws = tmp_path / "ws"
    _cmake_program(ws / "src", "homed", 'add_compile_definitions(BUILT_IN="$ENV{HOME}")',
                   '#include <cstdio>\nint main() { std::puts(BUILT_IN); }\n')
    _cmake_program(ws / "src", "plain", "", '#include <cstdio>\nint main() { std::puts("p"); }\n')
    alice, bob = str(tmp_path / "alice"), str(tmp_path / "bob")

    def fresh_build(home: str) -> subprocess.CompletedProcess[str]:
        for base in ("build", "install"):
            shutil.rmtree(ws / base, ignore_errors=True)
        return _build(ws, env=clean_env(HOME=home, USER=Path(home).name))

    fresh_build(alice)
    as_bob = fresh_build(bob)
    assert _restored(as_bob) == ["plain"] and _finished(as_bob) == ["homed", "plain"], \
        output(as_bob)
    assert _program(ws, "homed") == bob
    as_alice = fresh_build(alice)
    assert _restored(as_alice) == ["homed", "plain"], output(as_alice)
    assert _program(ws, "homed") == alice


# --------------------------------------------------------------------------- times


def test_a_back_dated_outside_header_is_compiled_and_cached_with_its_new_content(
        tmp_path: Path) -> None:
    """An outside header replaced by one with older times (`cp -p`, `tar x`): the build
    compiles it (Ninja alone would not), so the record and the cache entry name the new
    header over a binary built from it, and a fresh checkout restores the right one."""
    ws = tmp_path / "ws"
    include = tmp_path / "include"
    header = write(include / "answer.h", "#define ANSWER 41\n")
    _cmake_program(ws / "src", "answer", f'include_directories("{include}")',
                   '#include <cstdio>\n#include "answer.h"\nint main() { '
                   'std::printf("%d\\n", ANSWER); }\n')
    _settled(ws)
    old = header.stat()
    header.write_text("#define ANSWER 42\n")
    os.utime(header, ns=(old.st_atime_ns, old.st_mtime_ns - 10**10))
    result = _build(ws)
    assert _finished(result) == ["answer"], output(result)
    assert _program(ws, "answer") == "42"
    for base in ("build", "install"):
        shutil.rmtree(ws / base)
    fresh = _build(ws)
    assert _restored(fresh) == ["answer"], output(fresh)
    assert _program(ws, "answer") == "42"


# ---------------------------------------------------------------------------- tests


def _tested(ws: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return run("test", cwd=ws, env=env, timeout=600)


def _sourced(ws: Path) -> dict[str, str]:
    done = subprocess.run(["bash", "-c", "source install/setup.bash && env -0"], cwd=ws,
                          env=clean_env(), capture_output=True, text=True, check=True)
    return dict(item.split("=", 1) for item in done.stdout.split("\0") if "=" in item)


def test_a_test_that_imports_an_undeclared_workspace_package_runs_again_when_it_changes(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_ament_python(ws / "src", "shapes", modules={"sides.py": "SQUARE = 4\n"})
    user = write_ament_python(ws / "src", "geometry",
                              modules={"main.py": "def main():\n    pass\n"})
    write(user / "test" / "test_square.py",
          "from shapes.sides import SQUARE\n\n\ndef test_square():\n    assert SQUARE == 4\n")
    _build(ws)
    env = _sourced(ws)
    assert _tested(ws, env).returncode == 0
    cached = _tested(ws, env)
    assert "[geometry] cached" in cached.stdout, output(cached)
    write(ws / "src" / "shapes" / "shapes" / "sides.py", "SQUARE = 5\n")
    _build(ws, "--packages-select", "shapes")
    again = _tested(ws, env)
    assert again.returncode != 0 and "[geometry] cached" not in again.stdout, output(again)


def test_a_pytest_ini_above_the_package_reruns_its_tests(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    pkg = write_ament_python(ws / "src", "warned", modules={"main.py": "def main():\n    pass\n"})
    write(pkg / "test" / "test_warns.py", "import warnings\n\n\ndef test_warns():\n"
          "    warnings.warn('old api', DeprecationWarning)\n")
    _build(ws)
    env = clean_env()
    assert _tested(ws, env).returncode == 0
    assert "[warned] cached" in _tested(ws, env).stdout
    write(ws / "src" / "pytest.ini", "[pytest]\nfilterwarnings =\n    error\n")
    again = _tested(ws, env)
    assert again.returncode != 0 and "[warned] cached" not in again.stdout, output(again)


# --------------------------------------------------------------------------- the install


def test_a_package_moved_under_symlink_install_leaves_no_dangling_link(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_ament_python(ws / "src", "mover", modules={"main.py": "def main():\n    pass\n"},
                       data={"launch/mover.launch.py": "# a launch file\n"})
    _build(ws, "--symlink-install")
    time.sleep(1.1)
    assert _finished(_build(ws, "--symlink-install")) == []
    (ws / "src" / "nested").mkdir()
    (ws / "src" / "mover").rename(ws / "src" / "nested" / "mover")
    result = _build(ws, "--symlink-install")
    assert _finished(result) == ["mover"], output(result)
    links = [p for p in (ws / "install" / "mover").rglob("*") if p.is_symlink()]
    assert links and all(p.exists() for p in links), [str(p) for p in links if not p.exists()]


def test_an_installed_file_edited_in_place_keeping_its_size_is_put_back(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_ament_python(ws / "src", "kept", modules={"main.py": "def main():\n    pass\n"},
                       data={"config/kept.yaml": "speed: 1\n"})
    _settled(ws)
    installed = ws / "install" / "kept" / "share" / "kept" / "config" / "kept.yaml"
    installed.write_text("speed: 9\n")
    result = _build(ws)
    assert _finished(result) == ["kept"], output(result)
    assert installed.read_text() == "speed: 1\n"


# ---------------------------------------------------------------- undeclared dependencies


def test_a_package_that_reads_an_undeclared_workspace_package_is_named(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "provider", """
        cmake_minimum_required(VERSION 3.16)
        project(provider NONE)
        file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/providerConfig.cmake "set(PROVIDED yes)\\n")
        install(FILES ${CMAKE_CURRENT_BINARY_DIR}/providerConfig.cmake
                DESTINATION share/provider/cmake)
        install(FILES package.xml DESTINATION share/provider)
        """)
    write_cmake(ws / "src", "consumer", """
        cmake_minimum_required(VERSION 3.16)
        project(consumer NONE)
        find_package(provider REQUIRED)
        install(FILES package.xml DESTINATION share/consumer)
        """)
    _build(ws, "--packages-select", "provider")
    env = _sourced(ws)  # the consumer finds it through the sourced workspace only
    first = _build(ws, "--packages-select", "consumer", env=env)
    assert "consumer read install/provider" in first.stdout, output(first)
    assert "add `<depend>provider</depend>`" in first.stdout, output(first)
    strict = run("build", "--packages-select", "consumer", "--strict-dependencies",
                 "--cmake-force-configure", cwd=ws, env=env)
    assert strict.returncode != 0 and "does not declare provider" in strict.stdout, \
        output(strict)


def test_a_merged_install_is_a_no_op_after_its_build_and_a_neighbour_builds_alone(
        tmp_path: Path) -> None:
    """In a merged install every package lists the shared prefix (Python's import system,
    setuptools): what packages it does not depend on put there, and wsbuild's own stage, are
    no input of its build, so the build after a build is a no-op and an edit of one package
    rebuilds it and its dependents only."""
    ws = tmp_path / "ws"
    src = ws / "src"
    write_ament_python(src, "base_py", modules={"core.py": "X = 1\n"})
    write_ament_python(src, "user_py", modules={"main.py": "from base_py.core import X\n"},
                       depend=["base_py"])
    lone = write_ament_python(src, "lone_py", modules={"lone.py": "Y = 1\n"})
    # Python writes bytecode, as on most users' machines (a traced build then once waited
    # for ever for a setup.py helper)
    env = {k: v for k, v in clean_env().items() if k != "PYTHONDONTWRITEBYTECODE"}
    _build(ws, "--merge-install", env=env)
    time.sleep(1.1)
    again = _build(ws, "--merge-install", env=env)
    assert _finished(again) == [], output(again)
    write(lone / "lone_py" / "lone.py", "Y = 2\n")
    write(lone / "lone_py" / "extra.py", "Z = 3\n")
    edited = _build(ws, "--merge-install", env=env)
    assert _finished(edited) == ["lone_py"], output(edited)
    time.sleep(1.1)
    assert _finished(_build(ws, "--merge-install", env=env)) == []


#: a program that probes with null paths, as Rust's standard library does for statx (sccache,
#: a compiler cache wsbuild drives, does at its start), then reads a file
NULL_PROBES = r"""
#define _GNU_SOURCE
#include <fcntl.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>
int main(int argc, char **argv) {
    struct stat info;
    const char *volatile none = NULL;
    statx(0, none, 0, STATX_ALL, NULL);
    fstatat(AT_FDCWD, none, &info, 0);
    FILE *f = fopen(argv[1], "r");
    return f == NULL;
}
"""


def test_a_program_that_probes_with_null_paths_runs_observed_and_its_reads_are_seen(
        tmp_path: Path) -> None:
    """The observer must never change what a step does: a null path is passed through to the
    C library (which answers EFAULT), and the program's later reads are still written down."""
    from wsbuild.observe.library import observer
    from wsbuild.observe.step_environment import observed

    made = observer(tmp_path / "observer", os.environ)
    assert not isinstance(made, str), made
    write(tmp_path / "probe.c", NULL_PROBES)
    subprocess.run(["cc", "-O2", "-o", str(tmp_path / "probe"), str(tmp_path / "probe.c")],
                   check=True)
    read = tmp_path / "input.txt"
    read.write_text("x")
    logs = tmp_path / "logs"
    logs.mkdir()
    done = subprocess.run([str(tmp_path / "probe"), str(read)], capture_output=True, text=True,
                          env=observed(dict(os.environ), made, logs), timeout=60, check=False)
    assert done.returncode == 0, done.stderr
    lines = "".join(path.read_text() for path in logs.iterdir()).splitlines()
    assert f"R {read}" in lines
