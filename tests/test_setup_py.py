"""Reading setup() arguments through the warm helper processes, with real setuptools."""

from __future__ import annotations

import importlib.util
import marshal
import os
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path, PurePosixPath

import pytest

from wsbuild.build_types import StepFailed
from wsbuild.errors import ManifestError
from wsbuild.build_types.pybuild.setup_py import (
    SETUP_LOG,
    BuildSystem,
    compile_bytecode,
    helper_pids,
    read_build_system,
    read_setup,
    shutdown_helpers,
)


@pytest.fixture(autouse=True)
def _helpers() -> Iterator[None]:
    yield
    shutdown_helpers()


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def read(source: Path, tmp_path: Path, environ: dict[str, str] | None = None):
    return read_setup(source, tmp_path / "build" / source.name,
                      environ=dict(os.environ) if environ is None else environ,
                      python_executable=sys.executable)


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state != "Z"


def test_ament_package_plan(tmp_path: Path) -> None:
    source = tmp_path / "src" / "demo"
    write(source / "demo" / "__init__.py", "")
    write(source / "demo" / "node.py", "")
    write(source / "resource" / "demo", "")
    write(source / "launch" / "a.launch.py", "")
    write(source / "package.xml", "<package/>")
    write(source / "setup.cfg", "[install]\ninstall_scripts=$base/lib/demo\n")
    write(source / "setup.py", """\
from setuptools import setup
setup(name='demo', version='1.2.3', packages=['demo'],
      data_files=[('share/ament_index/resource_index/packages', ['resource/demo']),
                  ('share/demo', ['package.xml']),
                  ('share/demo/launch', ['launch/a.launch.py'])],
      entry_points={'console_scripts': ['node = demo.node:main']})
""")
    plan = read(source, tmp_path)
    assert plan.fast and plan.fallback_reasons == ()
    assert (plan.name, plan.version) == ("demo", "1.2.3")
    assert [(str(f.dest), f.source, f.package) for f in plan.files] == [
        ("demo/__init__.py", source / "demo" / "__init__.py", "demo"),
        ("demo/node.py", source / "demo" / "node.py", "demo"),
    ]
    assert [(str(d.directory), d.sources) for d in plan.data_files] == [
        ("share/ament_index/resource_index/packages", ("resource/demo",)),
        ("share/demo", ("package.xml",)),
        ("share/demo/launch", ("launch/a.launch.py",)),
    ]
    assert plan.install_scripts == "$base/lib/demo"
    assert plan.egg_info_dir == tmp_path / "build" / "demo" / "demo.egg-info"
    assert plan.egg_info_basename == \
        f"demo-1.2.3-py{sys.version_info[0]}.{sys.version_info[1]}.egg-info"
    assert "[console_scripts]" in (plan.egg_info_dir / "entry_points.txt").read_text()
    assert sorted(p.name for p in source.iterdir()) == [
        "demo", "launch", "package.xml", "resource", "setup.cfg", "setup.py"]


def test_custom_commands_ask_for_the_fallback_but_still_map_files(tmp_path: Path) -> None:
    source = tmp_path / "src" / "custom"
    write(source / "custom" / "__init__.py", "")
    write(source / "setup.py", """\
from setuptools import setup
from setuptools.command.build_py import build_py
class Mine(build_py):
    pass
setup(name='custom', version='1', packages=['custom'], cmdclass={'build_py': Mine},
      setup_requires=['never-installed'])
""")
    plan = read(source, tmp_path)
    assert not plan.fast
    assert plan.fallback_reasons == ("cmdclass overrides build_py", "setup_requires")
    assert [str(f.dest) for f in plan.files] == ["custom/__init__.py"]
    assert plan.egg_info_dir is None


def test_failing_setup_py_asks_for_the_fallback_and_keeps_its_output(tmp_path: Path) -> None:
    source = tmp_path / "src" / "broken"
    write(source / "setup.py", "print('about to fail')\nraise ValueError('no luck')\n")
    plan = read(source, tmp_path)
    assert plan.fallback_reasons == ("setup.py failed: ValueError: no luck",)
    log = (tmp_path / "build" / "broken" / SETUP_LOG).read_text()
    assert "about to fail" in log and "ValueError: no luck" in log


def test_setup_py_without_setup_call(tmp_path: Path) -> None:
    source = tmp_path / "src" / "nosetup"
    write(source / "setup.py", "x = 1\n")
    assert read(source, tmp_path).fallback_reasons == ("setup.py does not call setup()",)


def test_each_request_sees_its_own_environment(tmp_path: Path) -> None:
    # a setup.py that imports from a dependency's prefix (PYTHONPATH differs per package)
    results = []
    for version in ("1.0", "2.0"):
        dep = write(tmp_path / f"dep{version}" / "shared_version.py", f"VERSION = '{version}'\n")
        source = tmp_path / "src" / f"user{version[0]}"
        write(source / "setup.py", """\
import os
from setuptools import setup
from shared_version import VERSION
setup(name='user', version=VERSION + '.' + os.environ['EXTRA'], py_modules=[])
""")
        env = dict(os.environ, PYTHONPATH=str(dep.parent), EXTRA=version[0])
        results.append(read(source, tmp_path, env).version)
    assert results == ["1.0.1", "2.0.2"]
    assert len(helper_pids()) == 1  # the second request reused the warm helper


def test_concurrent_requests_from_threads(tmp_path: Path) -> None:
    sources = []
    for index in range(6):
        source = tmp_path / "src" / f"pkg{index}"
        write(source / f"mod{index}.py", "")
        write(source / "setup.py", "import time\nfrom setuptools import setup\ntime.sleep(0.05)\n"
              f"setup(name='pkg{index}', version='{index}.0', py_modules=['mod{index}'])\n")
        sources.append(source)
    results: dict[int, str] = {}

    def work(index: int) -> None:
        plan = read(sources[index], tmp_path)
        results[index] = f"{plan.name} {plan.version} {plan.files[0].dest}"

    threads = [threading.Thread(target=work, args=(i,)) for i in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert results == {i: f"pkg{i} {i}.0 mod{i}.py" for i in range(6)}
    assert 1 <= len(helper_pids()) <= max(1, min(4, os.cpu_count() or 1))


def test_shutdown_stops_helpers_and_a_running_setup_py(tmp_path: Path) -> None:
    source = tmp_path / "src" / "slow"
    started = tmp_path / "started"
    write(source / "setup.py", f"import os, time\nopen({str(started)!r}, 'w').write("
          "str(os.getpid()))\ntime.sleep(60)\n")
    errors: list[BaseException] = []

    def work() -> None:
        try:
            read(source, tmp_path)
        except BaseException as exc:  # noqa: BLE001 - collected for the assertion
            errors.append(exc)

    thread = threading.Thread(target=work)
    thread.start()
    deadline = time.monotonic() + 20
    while not started.exists() or not started.read_text():
        assert time.monotonic() < deadline
        time.sleep(0.01)
    child = int(started.read_text())
    helpers = helper_pids()
    shutdown_helpers()
    thread.join(timeout=10)
    assert not thread.is_alive()
    assert len(errors) == 1 and isinstance(errors[0], StepFailed)
    assert helper_pids() == ()
    deadline = time.monotonic() + 5  # SIGKILL is delivered asynchronously
    while any(alive(pid) for pid in (*helpers, child)) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert not any(alive(pid) for pid in (*helpers, child))


def test_compile_bytecode_records_final_path_and_reports_errors(tmp_path: Path) -> None:
    good = write(tmp_path / "stage" / "good.py", "X = 1\n")
    bad = write(tmp_path / "stage" / "bad.py", "def (:\n")
    final = Path("/opt/final/good.py")
    errors = compile_bytecode([(good, final), (bad, Path("/opt/final/bad.py"))],
                              environ=dict(os.environ), python_executable=sys.executable)
    assert len(errors) == 1 and errors[0].startswith("/opt/final/bad.py")
    cache = Path(importlib.util.cache_from_source(str(good)))
    assert marshal.loads(cache.read_bytes()[16:]).co_filename == str(final)


def test_build_system_defaults_to_setuptools_legacy(tmp_path: Path) -> None:
    assert read_build_system(tmp_path) == BuildSystem()
    assert BuildSystem().fast_path_blocker() is None
    write(tmp_path / "pyproject.toml", "[tool.black]\nline-length = 99\n")
    assert read_build_system(tmp_path).is_setuptools


def test_build_system_reports_what_blocks_the_fast_path(tmp_path: Path) -> None:
    write(tmp_path / "pyproject.toml", '[build-system]\nrequires = ["hatchling"]\n'
          'build-backend = "hatchling.build"\n')
    assert read_build_system(tmp_path).fast_path_blocker() == "build backend hatchling.build"
    write(tmp_path / "pyproject.toml", '[build-system]\nrequires = ["setuptools>=64", '
          '"setuptools_scm[toml]>=8", "wheel"]\nbuild-backend = "setuptools.build_meta"\n')
    assert read_build_system(tmp_path).fast_path_blocker() == \
        "build requirements setuptools-scm"


def test_invalid_pyproject_names_the_file(tmp_path: Path) -> None:
    path = write(tmp_path / "pyproject.toml", "[build-system\n")
    with pytest.raises(ManifestError) as info:
        read_build_system(tmp_path)
    assert info.value.path == path
    write(tmp_path / "pyproject.toml", '[build-system]\nrequires = "setuptools"\n')
    with pytest.raises(ManifestError, match="wrong type"):
        read_build_system(tmp_path)


def test_module_file_destinations_are_posix(tmp_path: Path) -> None:
    source = tmp_path / "src" / "nested"
    write(source / "a" / "__init__.py", "")
    write(source / "a" / "b" / "__init__.py", "")
    write(source / "a" / "b" / "res.txt", "")
    write(source / "setup.py", "from setuptools import setup\nsetup(name='nested', "
          "version='1', packages=['a', 'a.b'], package_data={'a.b': ['*.txt']})\n")
    plan = read(source, tmp_path)
    assert [f.dest for f in plan.files] == [PurePosixPath(p) for p in (
        "a/__init__.py", "a/b/__init__.py", "a/b/res.txt")]
    assert [f.package for f in plan.files] == ["a", "a.b", "a.b"]
