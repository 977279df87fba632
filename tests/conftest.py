"""Shared fixtures: tiny real workspaces written from a dict, a way to run the CLI, the colcon
oracle; and the check that fails a run in which a test was skipped for an unexpected reason."""

from __future__ import annotations

import fcntl
import os
import shutil
import signal
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent

# The suite runs wsbuild in its default configuration: the local build cache is on, so every
# "up to date", "restored" and "cached" it answers is tested as users get it. The cache lives in
# a directory of the session's own (pytest_configure; removed at its end), not ~/.cache/wsbuild;
# a test that needs the cache off says why.
CACHE_VARIABLE = "WSBUILD_CACHE_DIR"
# DDS stays on this machine however the suite is started (scripts/test.sh exports it too); a
# run in-process and one in a subprocess then see one environment
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

# The inputs oracle (engine/inputs_oracle.py): every wsbuild run the suite records also traces
# its own file accesses and writes down those no declaration (wsbuild/inputs.py) covers. Each
# pytest session that is not an xdist worker owns a file of its own (pytest_configure; a
# session a test starts gets its own too), inherited by its workers and every wsbuild they
# start; a non-empty file fails the session, naming the paths and the code that read them.
ORACLE_VARIABLE = "WSBUILD_INPUTS_ORACLE"


def pytest_configure(config: pytest.Config) -> None:
    if hasattr(config, "workerinput"):
        return  # an xdist worker: its controller's file and cache
    oracle_dir = REPO / ".pytest_cache"
    oracle_dir.mkdir(exist_ok=True)
    oracle = oracle_dir / f"inputs-oracle-{os.getpid()}.txt"
    oracle.unlink(missing_ok=True)
    os.environ[ORACLE_VARIABLE] = str(oracle)
    step_oracle = oracle_dir / f"step-oracle-{os.getpid()}.txt"
    for stale in (step_oracle, Path(f"{step_oracle}.checked")):
        stale.unlink(missing_ok=True)
    os.environ[SUITE_STEP_ORACLE] = str(step_oracle)
    os.environ.pop(STEP_ORACLE_VARIABLE, None)  # on only where a test asks for it
    os.environ.pop("WSBUILD_CACHE", None)  # a developer's remote cache or `off`: not here
    os.environ[CACHE_VARIABLE] = tempfile.mkdtemp(prefix="wsbuild-suite-cache-")


def _oracle_file() -> Path:
    return Path(os.environ[ORACLE_VARIABLE])


# The build-step oracle (builder/oracles/step_trace.py): the builds of the tests that use the
# `traced_steps` fixture run each build step under strace, and write down every file a step
# read that the package's record does not hold; a non-empty file fails the session, naming
# the package, the step and the file.
STEP_ORACLE_VARIABLE = "WSBUILD_STEP_TRACE"
SUITE_STEP_ORACLE = "WSBUILD_SUITE_STEP_ORACLE"


def _step_oracle_file() -> Path:
    return Path(os.environ[SUITE_STEP_ORACLE])


def _findings(own: Path, session: Path) -> list[str]:
    """What an oracle wrote into a test's own file, added to the session's (the summary)."""
    lines: list[str] = []
    for path in (own, Path(f"{own}.checked")):
        try:
            text = path.read_text()
        except FileNotFoundError:
            continue
        target = session if path == own else Path(f"{session}.checked")
        with open(target, "a", encoding="utf-8") as handle:
            handle.write(text)
        if path == own:
            lines = [line for line in text.splitlines() if line and not line.startswith("#")]
    return lines


@pytest.fixture(autouse=True)
def inputs_oracle(monkeypatch: pytest.MonkeyPatch, tmp_path_factory: pytest.TempPathFactory
                  ) -> Iterator[Path]:
    """Every test's recorded wsbuild runs write what the planning oracle found into a file
    of the test's own: a finding fails the test that caused it (and the session's file keeps
    it for the summary)."""
    session = _oracle_file()
    own = tmp_path_factory.mktemp("inputs-oracle") / "inputs-oracle.txt"
    monkeypatch.setenv(ORACLE_VARIABLE, str(own))
    yield own
    found = _findings(own, session)
    if found:
        pytest.fail("the planning oracle found undeclared inputs (wsbuild/inputs.py):\n"
                    + "\n".join(found[:20]), pytrace=False)


@pytest.fixture
def traced_steps(monkeypatch: pytest.MonkeyPatch, tmp_path_factory: pytest.TempPathFactory
                 ) -> Iterator[Path]:
    """The builds this test starts run their steps under the build-step oracle (strace, held
    against each package's record: builder/oracles/step_trace.py); a read no record holds fails this
    test. Their compiles go through ccache (`--compiler-cache auto` finds the ccache
    scripts/setup.sh installs): the oracle sees a compiler ccache runs, not one sccache's
    server runs, outside every step."""
    own = tmp_path_factory.mktemp("step-oracle") / "step-oracle.txt"
    monkeypatch.setenv(STEP_ORACLE_VARIABLE, str(own))
    yield own
    found = _findings(own, _step_oracle_file())
    if found:
        pytest.fail("the build-step oracle found reads no package record holds "
                    "(builder/oracles/step_trace.py):\n" + "\n".join(found[:20]), pytrace=False)

PACKAGE_XML = """<?xml version="1.0"?>
<package format="3">
  <name>{name}</name>
  <version>{version}</version>
  <description>Test package {name}</description>
  <maintainer email="dev@example.com">Dev</maintainer>
  <license>Apache-2.0</license>
{deps}
  <export>
    <build_type>{build_type}</build_type>
  </export>
</package>
"""

SETUP_PY = """from setuptools import setup

package_name = {name!r}

setup(
    name=package_name,
    version='0.1.0',
    packages=[package_name],
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    zip_safe=True,
    entry_points={{'console_scripts': ['{name}_main = {name}.main:main']}},
)
"""

SETUP_CFG = """[develop]
script_dir=$base/lib/{name}
[install]
install_scripts=$base/lib/{name}
"""

CMAKELISTS = """cmake_minimum_required(VERSION 3.14)
project({name} NONE)
install(FILES package.xml DESTINATION share/{name})
"""

Spec = tuple[str, Sequence[str]] | tuple[str, Sequence[str], Mapping[str, Sequence[str]]]


def write_package(
    root: Path,
    name: str,
    build_type: str = "ament_python",
    deps: Sequence[str] = (),
    *,
    kinds: Mapping[str, Sequence[str]] | None = None,
    subdir: str = "",
    version: str = "0.1.0",
) -> Path:
    """Write a small but real package: package.xml plus setup.py or CMakeLists.txt."""
    path = root / subdir / name if subdir else root / name
    path.mkdir(parents=True, exist_ok=True)
    tags = [f"  <depend>{d}</depend>" for d in deps]
    for tag, names in (kinds or {}).items():
        tags += [f"  <{tag}>{d}</{tag}>" for d in names]
    (path / "package.xml").write_text(
        PACKAGE_XML.format(name=name, version=version, deps="\n".join(tags), build_type=build_type)
    )
    if build_type == "ament_python":
        (path / "setup.py").write_text(SETUP_PY.format(name=name))
        (path / "setup.cfg").write_text(SETUP_CFG.format(name=name))
        (path / "resource").mkdir(exist_ok=True)
        (path / "resource" / name).write_text("")
        (path / name).mkdir(exist_ok=True)
        (path / name / "__init__.py").write_text("")
        (path / name / "main.py").write_text(
            f"def main():\n    print('hello from {name}')\n"
        )
    elif build_type in ("ament_cmake", "cmake"):
        (path / "CMakeLists.txt").write_text(CMAKELISTS.format(name=name))
    return path


@pytest.fixture
def make_workspace(tmp_path: Path) -> Callable[[Mapping[str, Spec]], Path]:
    """`make_workspace({"a": ("ament_python", ["b"]), "b": ("cmake", [])})` → workspace root."""

    def make(spec: Mapping[str, Spec], root: Path | None = None) -> Path:
        ws = root or tmp_path / "ws"
        (ws / "src").mkdir(parents=True, exist_ok=True)
        for name, entry in spec.items():
            build_type, deps = entry[0], entry[1]
            kinds = entry[2] if len(entry) > 2 else None  # type: ignore[misc]
            write_package(ws / "src", name, build_type, deps, kinds=kinds)
        return ws

    return make


def sigint_at_default() -> None:
    """`preexec_fn` of a process a test sends SIGINT (Ctrl-C) to: it starts with SIGINT at its
    default action. A suite started with SIGINT ignored (a background job of a non-interactive
    shell, `trap "" INT`) would hand that on through every exec: Python then installs no
    KeyboardInterrupt handler and the process never sees the test's Ctrl-C."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def run_wsbuild(*args: str, cwd: Path, env: Mapping[str, str] | None = None,
                timeout: float = 600) -> subprocess.CompletedProcess[str]:
    """Run the real command line in a subprocess, as a user would."""
    full_env = dict(os.environ if env is None else env)
    full_env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return subprocess.run(
        [sys.executable, "-m", "wsbuild", *args],
        cwd=cwd, env=full_env, capture_output=True, text=True, timeout=timeout,
    )


def needing_a_missing_distribution(tmp_path: Path) -> tuple[Path, Path]:
    """A workspace whose one package build-depends on a Python distribution nothing provides
    (`python3-wsb-probe-dist`), and an empty site directory to put on PYTHONPATH and install
    it into (`install_probe_distribution`): (workspace, site)."""
    ws = tmp_path / "ws"
    package = write_package(ws / "src", "needs_it", "ament_python")
    manifest = package / "package.xml"
    manifest.write_text(manifest.read_text().replace(
        "</package>", "  <build_depend>python3-wsb-probe-dist</build_depend>\n</package>"))
    site = tmp_path / "site"
    site.mkdir()
    return ws, site


def install_probe_distribution(site: Path) -> Path:
    """What pip leaves in `site` for an installed wheel of wsb-probe-dist; its dist-info."""
    info = site / "wsb_probe_dist-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: wsb-probe-dist\nVersion: 1.0\n")
    (info / "RECORD").write_text("")
    return info


#: two ament_python packages (pb depends on pa) and a plain cmake one
SMALL_SPEC: dict[str, Spec] = {"pa": ("ament_python", []), "pb": ("ament_python", ["pa"]),
                               "pc": ("cmake", [])}


@pytest.fixture
def built(make_workspace: Callable[..., Path]) -> Path:
    """SMALL_SPEC's workspace, built once with no options."""
    ws = make_workspace(SMALL_SPEC)
    result = run_wsbuild("build", cwd=ws)
    assert result.returncode == 0, result.stdout + result.stderr
    return ws


@pytest.fixture
def wsbuild() -> Callable[..., subprocess.CompletedProcess[str]]:
    return run_wsbuild


# ------------------------------------------------------------------------- the colcon oracle

#: variables a sourced workspace or the wheels' bootstrapper set: the oracle is made without them
_SOURCED = ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "COLCON_PREFIX_PATH", "PYTHONPATH",
            "LD_LIBRARY_PATH", "VIRTUAL_ENV", "_ROS_WHEELS_BOOTSTRAP_COMPLETE")


@pytest.fixture(scope="session")
def colcon(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The `colcon` executable of a virtualenv with colcon-common-extensions (and colcon-mixin,
    which is not among them) from PyPI: the oracle
    the interop and corpus tests hold wsbuild against. Made once per run; the xdist workers share
    it through a lock in their common temporary directory.

    colcon runs setup.py with its own interpreter, which then becomes the console scripts'
    shebang: like a user who pip-installs colcon into the ROS virtualenv, that interpreter must
    see the ROS Python packages, so the colcon venv gets a .pth file adding the ROS venv's
    site-packages.
    """
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent  # the directory all workers of this run have in common
    root = base / "colcon-oracle"
    root.mkdir(exist_ok=True)
    venv = root / "venv"
    with open(root / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (root / "ready").exists():
            _make_colcon_venv(venv)
            (root / "ready").write_text("")
    return venv / "bin" / "colcon"


def _make_colcon_venv(venv: Path) -> None:
    from wsbuild.underlay.detect import find_venv_underlay

    env = {k: v for k, v in os.environ.items() if k not in _SOURCED}
    made = subprocess.run([sys.executable, "-m", "venv", str(venv)], env=env,
                          capture_output=True, text=True, check=False)
    if made.returncode != 0:
        pytest.fail(f"cannot create a virtualenv for colcon: {made.stderr[-500:]}")
    pip = subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "install", "-q",
                          "colcon-common-extensions", "colcon-mixin"], env=env, capture_output=True, text=True,
                         timeout=900, check=False)
    if pip.returncode != 0:
        pytest.fail(f"cannot pip install colcon-common-extensions: {pip.stderr[-500:]}")
    ros = find_venv_underlay(os.environ, sys.executable)
    if ros is not None:
        ros_site = next((ros / "lib").glob("python3*/site-packages"))
        own_site = next((venv / "lib").glob("python3*/site-packages"))
        (own_site / "zz_ros_underlay.pth").write_text(
            f"import site; site.addsitedir({str(ros_site)!r})\n")


# ----------------------------------------------------------------------- no unexpected skips

#: the only reasons a test may skip for (a prefix of the reason): what the machine cannot offer
#: and scripts/setup.sh cannot install. Any other skip fails the run, so that a test that quietly
#: stopped running (a tool missing, a fixed path) is noticed.
ALLOWED_SKIPS: tuple[str, ...] = (
    "not on this OS",
    # test_build_environment_failures.py without root or user namespaces; as root (CI) they can
    # mount, so there the skip fails the run
    *(("this machine lets tests mount nothing",) if os.geteuid() != 0 else ()),
)

_unexpected_skips: list[str] = []


def _skip_reason(report: pytest.TestReport) -> str:
    longrepr = report.longrepr
    if isinstance(longrepr, tuple) and len(longrepr) == 3:
        return str(longrepr[2]).removeprefix("Skipped: ")
    return str(longrepr)


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """Note each skip whose reason is not allowed (xdist replays workers' reports here)."""
    if report.skipped and not hasattr(report, "wasxfail"):
        reason = _skip_reason(report)
        if not reason.startswith(ALLOWED_SKIPS):
            _unexpected_skips.append(f"{report.nodeid}: {reason}")


def _undeclared_inputs() -> list[str]:
    try:
        return _oracle_file().read_text().splitlines()
    except FileNotFoundError:
        return []


def _unrecorded_reads() -> list[str]:
    try:
        return _step_oracle_file().read_text().splitlines()
    except FileNotFoundError:
        return []


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    if hasattr(session.config, "workerinput"):
        return  # an xdist worker: the controller counts and decides
    shutil.rmtree(os.environ.get(CACHE_VARIABLE, ""), ignore_errors=True)
    if (_unexpected_skips or _undeclared_inputs() or _unrecorded_reads()) and exitstatus == 0:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    if hasattr(terminalreporter.config, "workerinput"):
        return
    for line in _unexpected_skips:
        terminalreporter.write_line(f"UNEXPECTED SKIP {line}")
    undeclared = _undeclared_inputs()
    for line in undeclared:
        terminalreporter.write_line(f"UNDECLARED INPUT {line}")
    terminalreporter.write_line(
        f"{sum(1 for line in undeclared if not line.startswith('#'))} undeclared inputs of "
        f"recorded runs (wsbuild/inputs.py; the oracle's file: {_oracle_file()})")
    unrecorded = _unrecorded_reads()
    for line in unrecorded:
        terminalreporter.write_line(f"UNRECORDED READ {line}")
    try:
        checked = Path(f"{_step_oracle_file()}.checked").read_text().splitlines()
    except FileNotFoundError:
        checked = []
    terminalreporter.write_line(
        f"{len(unrecorded)} reads of build steps no package record holds, in "
        f"{len(checked)} traced package builds (builder/oracles/step_trace.py; the oracle's file: "
        f"{_step_oracle_file()})")
    terminalreporter.write_line(
        f"{len(_unexpected_skips)} unexpected skips (allowed: {'; '.join(ALLOWED_SKIPS)})")
