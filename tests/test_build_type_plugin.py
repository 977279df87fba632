"""Build types own what wsbuild knows about them, and another distribution's build type gets
what the built-ins get: it builds, gets environment hooks and runs its tests."""

from __future__ import annotations

import ast
import os
import stat
import subprocess
from importlib.metadata import entry_points
from pathlib import Path

from conftest import run_wsbuild

from wsbuild.build_types import BUILTIN, BUILTIN_ENTRY_POINTS, ENTRY_POINT_GROUP, get_build_type

PACKAGE = Path(__file__).resolve().parent.parent / "wsbuild"

PLUGIN = '''
"""A third-party build type: installs share/ and bin/ of a package as they are; its tests are
a shell script that writes JUnit (neither pytest nor CTest)."""
import shutil
from dataclasses import dataclass
from wsbuild.build_types import BuildTypeBase, Command, Step
from wsbuild.build_types.test_runner import TestOutcome, TestRunner, TestRunnerBase, read_or_error
from wsbuild.prefix.hooks import EnvironmentHooks


def install(ctx):
    share = ctx.stage_prefix / "share" / ctx.package.name
    shutil.copytree(ctx.source_dir / "data", share / "data")
    (ctx.stage_prefix / "bin").mkdir(parents=True, exist_ok=True)
    for script in sorted((ctx.source_dir / "scripts").iterdir()):
        shutil.copy2(script, ctx.stage_prefix / "bin" / script.name)


@dataclass(frozen=True, slots=True)
class CheckMaps(TestRunnerBase):
    name: str = "checkmaps"

    def command(self, ctx):
        return Command(("sh", "--", "test/check_maps.sh", str(ctx.results_dir / "checkmaps.xml"),
                        str(ctx.build_dir / "runs.txt")), ctx.package.path)

    def run(self, ctx):
        completed = ctx.run(self.command(ctx))
        junit = ctx.results_dir / "checkmaps.xml"
        return TestOutcome((read_or_error(junit, ctx.name, self.name, completed),))


@dataclass(frozen=True, slots=True)
class CopyBuildType(BuildTypeBase):
    name: str = "wsb_copy"
    test_runner: TestRunner | None = CheckMaps()
    hooks: EnvironmentHooks = EnvironmentHooks(ament=True)

    def steps(self, ctx):
        return [Step("copy", install)]


BUILD_TYPE = CopyBuildType()
'''

MANIFEST = """<?xml version="1.0"?>
<package format="3">
  <name>maps</name>
  <version>1.0.0</version>
  <description>map files</description>
  <maintainer email="m@example.com">M</maintainer>
  <license>Apache-2.0</license>
  <export><build_type>wsb_copy</build_type></export>
</package>
"""

#: the package's tests: the installed data is found through AMENT_PREFIX_PATH, the installed
#: script is on PATH; one test skipped; each run counted in the file named by $2
PACKAGE_TEST = '''#!/bin/sh
echo run >> "$2"
data=1
IFS=:
for prefix in $AMENT_PREFIX_PATH; do
    grep -qx "resolution: 0.05" "$prefix/share/maps/data/floor.yaml" 2>/dev/null && data=0
done
unset IFS
[ "$(show_map)" = map ]
script=$?
verdict() {
    if [ "$2" = 0 ]; then echo "  <testcase classname='maps' name='$1'/>"
    else echo "  <testcase classname='maps' name='$1'><failure message='$1'/></testcase>"; fi
}
mkdir -p "$(dirname "$1")"
{
    echo '<?xml version="1.0" encoding="UTF-8"?>'
    echo '<testsuite name="maps">'
    verdict data_found_through_ament_prefix_path $data
    verdict script_on_path $script
    echo '  <testcase classname="maps" name="slam_map"><skipped message="no slam map"/></testcase>'
    echo '</testsuite>'
} > "$1"
'''


def _plugin_distribution(root: Path, name: str = "wsb_copy", source: str = PLUGIN) -> Path:
    """A tiny installed distribution: module `<name>_type` and its dist-info registering
    build type `name`."""
    module = f"{name}_type"
    root.mkdir()
    (root / f"{module}.py").write_text(source)
    info = root / f"{module}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(
        f"Metadata-Version: 2.1\nName: {module.replace('_', '-')}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        f"[{ENTRY_POINT_GROUP}]\n{name} = {module}:BUILD_TYPE\n")
    return root


def test_a_third_party_build_type_builds_gets_hooks_and_runs_its_tests(tmp_path: Path) -> None:
    plugins = _plugin_distribution(tmp_path / "plugins")
    ws = tmp_path / "ws"
    package = ws / "src" / "maps"
    (package / "data").mkdir(parents=True)
    (package / "scripts").mkdir()
    (package / "test").mkdir()
    (package / "package.xml").write_text(MANIFEST)
    (package / "data" / "floor.yaml").write_text("resolution: 0.05\n")
    script = package / "scripts" / "show_map"
    script.write_text("#!/bin/sh\necho map\n")
    script.chmod(0o755)
    (package / "test" / "check_maps.sh").write_text(PACKAGE_TEST)
    env = {**os.environ, "PYTHONPATH": str(plugins)}

    # its step in the old form, `Step(label, action)`: in-process, said so by the dry run
    planned = run_wsbuild("build", "--dry-run", "--commands", cwd=ws, env=env)
    assert planned.returncode == 0, planned.stdout + planned.stderr
    assert "  # (in wsbuild) copy (no command to show)" in planned.stdout.splitlines()

    built = run_wsbuild("build", cwd=ws, env=env)
    assert built.returncode == 0, built.stdout + built.stderr
    prefix = ws / "install" / "maps"
    assert (prefix / "share" / "maps" / "data" / "floor.yaml").is_file()
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "maps").is_file()
    hooks = sorted(p.name for p in (prefix / "share" / "maps" / "hook").iterdir())
    assert "ament_prefix_path.dsv" in hooks and "path.dsv" in hooks

    # its own test runner runs its tests, and its JUnit makes the counts
    tested = run_wsbuild("test", cwd=ws, env=env)
    assert tested.returncode == 0, tested.stdout + tested.stderr
    assert "1 package tested, 3 tests, 0 errors, 0 failures, 1 skipped" in tested.stdout, \
        tested.stdout
    assert "1 package passed: maps" in tested.stdout, tested.stdout
    runs = ws / "build" / "maps" / "runs.txt"
    assert runs.read_text() == "run\n"
    # its pass is reused while nothing its tests observe changed
    again = run_wsbuild("test", cwd=ws, env=env)
    assert again.returncode == 0, again.stdout + again.stderr
    assert "[maps] cached: 3 tests, 0 errors, 0 failures, 1 skipped" in again.stdout, again.stdout
    assert runs.read_text() == "run\n"
    # and `test-result` reads what it wrote
    results = run_wsbuild("test-result", "--all", cwd=ws, env=env)
    assert "build/maps/test_results/maps/checkmaps.xml: 3 tests, 0 errors, 0 failures, " \
        "1 skipped" in results.stdout.splitlines(), results.stdout
    # rebuilt, it runs again; a failing test of its own fails the package
    (package / "data" / "floor.yaml").write_text("resolution: 0.1\n")
    assert run_wsbuild("build", cwd=ws, env=env).returncode == 0
    failed = run_wsbuild("test", cwd=ws, env=env)
    assert failed.returncode == 1, failed.stdout + failed.stderr
    assert "FAILED maps.data_found_through_ament_prefix_path" in failed.stdout, failed.stdout
    assert runs.read_text() == "run\nrun\n"

    # without the distribution, the package's build type is unknown: one clear error
    missing = run_wsbuild("build", cwd=ws)
    assert missing.returncode == 2
    assert "unknown build type 'wsb_copy'" in missing.stderr


def test_the_built_in_build_types_register_through_the_entry_point_group() -> None:
    registered = {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}
    assert set(BUILTIN) <= set(registered)
    for name in BUILTIN:
        assert registered[name].value == BUILTIN_ENTRY_POINTS[name]
        assert registered[name].load() is get_build_type(name)


def _is_build_type(node: ast.AST) -> bool:
    """`build_type`, `package.build_type`, `x.build_type`: a package's build-type string."""
    return (isinstance(node, ast.Name) and node.id == "build_type") or \
        (isinstance(node, ast.Attribute) and node.attr == "build_type")


def _is_fixed(node: ast.AST) -> bool:
    """A string, a collection of strings, or a module constant (`CMAKE_BUILD_TYPES`)."""
    if isinstance(node, ast.Constant):
        return isinstance(node.value, str)
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return any(_is_fixed(e) for e in node.elts)
    if isinstance(node, ast.Call) and getattr(node.func, "id", "") in ("frozenset", "set"):
        return any(_is_fixed(a) for a in node.args)
    return isinstance(node, ast.Name) and node.id.isupper()


def test_no_build_type_string_is_compared_outside_build_types() -> None:
    """What a build type means lives in its module: nothing else asks
    `package.build_type == "ament_cmake"` or keeps a set of build-type names to test against."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.is_relative_to(PACKAGE / "build_types"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare):
                operands = [node.left, *node.comparators]
                if any(_is_build_type(o) for o in operands) and any(_is_fixed(o)
                                                                    for o in operands):
                    found.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}")
            elif isinstance(node, ast.Assign) and any(
                    isinstance(target, ast.Name) and "BUILD_TYPES" in target.id
                    for target in node.targets) and _is_fixed(node.value):
                found.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}")
    assert not found, "build types own what they mean; compared at: " + ", ".join(found)


def test_the_build_type_check_finds_a_comparison(tmp_path: Path) -> None:
    """The check above is not blind: the shapes it forbids are found."""
    samples = ['if package.build_type == "ament_cmake": pass',
               'if build_type in ("cmake", "ament_cmake"): pass',
               'CMAKE_BUILD_TYPES = frozenset({"cmake"})']
    for sample in samples:
        tree = ast.parse(sample)
        compares = [n for n in ast.walk(tree) if isinstance(n, ast.Compare)]
        assigns = [n for n in ast.walk(tree) if isinstance(n, ast.Assign)]
        assert any(any(_is_build_type(o) for o in [c.left, *c.comparators]) and
                   any(_is_fixed(o) for o in [c.left, *c.comparators]) for c in compares) or \
            any(_is_fixed(a.value) for a in assigns), sample


#: the example plugin of docs/examples/wsb_map (its module, as a distribution installs it)
EXAMPLE = Path(__file__).resolve().parent.parent / "docs" / "examples" / "wsb_map"
MAP_PLUGIN = (EXAMPLE / "wsb_map_type.py").read_text()


def _map_distribution(root: Path) -> Path:
    """The example as a distribution installs it: its build type, and its identifier."""
    found = _plugin_distribution(root, "wsb_map", MAP_PLUGIN)
    with (found / "wsb_map_type-0.1.dist-info" / "entry_points.txt").open("a") as handle:
        handle.write("[wsbuild.package_identification]\nwsb_map = wsb_map_type:identify\n")
    return found


def _map_workspace(ws: Path) -> None:
    package = ws / "src" / "maps"
    package.mkdir(parents=True)
    (package / "package.xml").write_text(MANIFEST.replace("wsb_copy", "wsb_map"))


def test_a_third_party_option_reaches_its_packages_build_dry_run_and_by_hand_alike(
        tmp_path: Path) -> None:
    """The type's own option is on `build --help`, reaches its package's in-process step, is
    printed by the dry run with the command that does the step by hand, and enters the
    package's key: the build, the dry run and the pasted command agree, from one context."""
    env = {**os.environ, "PYTHONPATH": str(_map_distribution(tmp_path / "plugins"))}
    ws, by_hand = tmp_path / "ws", tmp_path / "by_hand"
    _map_workspace(ws)
    _map_workspace(by_hand)
    written = Path("install") / "maps" / "share" / "maps" / "resolution.txt"

    helped = run_wsbuild("build", "--help", cwd=ws, env=env)
    assert helped.returncode == 0, helped.stderr
    assert "wsb_map packages:" in helped.stdout
    assert "--map-resolution METRES" in helped.stdout

    planned = run_wsbuild("build", "--dry-run", "--commands", "--map-resolution", "0.05", cwd=ws, env=env)
    assert planned.returncode == 0, planned.stdout + planned.stderr
    lines = planned.stdout.splitlines()
    step = lines.index(f"  # (in wsbuild) write the map resolution 0.05: {written}")
    command = lines[step + 1].strip()
    assert command.endswith(f" {ws / written} 0.05"), command
    # by hand: the printed command, pasted into a shell in another checkout of the workspace
    pasted = subprocess.run(["bash", "-c", command.replace(str(ws), str(by_hand))],
                            cwd=by_hand, capture_output=True, text=True, timeout=60)
    assert pasted.returncode == 0, pasted.stderr
    built = run_wsbuild("build", "--map-resolution", "0.05", cwd=ws, env=env)
    assert built.returncode == 0, built.stdout + built.stderr
    assert (ws / written).read_text() == (by_hand / written).read_text() == "0.05\n"

    # the option is in the package's key: the same value is up to date, another rebuilds
    same = run_wsbuild("build", "--map-resolution", "0.05", cwd=ws, env=env)
    assert "1 package up to date" in same.stdout or "[maps] up to date" in same.stdout, \
        same.stdout
    changed = run_wsbuild("build", "--dry-run", "--commands", "--map-resolution", "0.1", cwd=ws, env=env)
    assert "build options changed: map_resolution: 0.05 → 0.1" in changed.stdout, \
        changed.stdout
    assert run_wsbuild("build", "--map-resolution", "0.1", cwd=ws, env=env).returncode == 0
    assert (ws / written).read_text() == "0.1\n"
    # a defaults file sets it as the command line does
    defaults = tmp_path / "defaults.yaml"
    defaults.write_text("build:\n  map-resolution: '0.2'\n")
    from_file = run_wsbuild("build", cwd=ws, env={**env, "COLCON_DEFAULTS_FILE": str(defaults)})
    assert from_file.returncode == 0, from_file.stdout + from_file.stderr
    assert (ws / written).read_text() == "0.2\n"

    # a built-in type knows nothing of it: a wsbuild without the distribution refuses it
    unknown = run_wsbuild("build", "--map-resolution", "0.1", cwd=ws)
    assert unknown.returncode == 2
    assert "unrecognized arguments: --map-resolution" in unknown.stderr


def test_the_built_in_types_options_are_the_ones_the_parser_reads() -> None:
    """The parser reads the built-in types' options without importing the types
    (BUILTIN_OPTIONS); colcon.meta's per-package keys are their list options."""
    from wsbuild.build_types import declared_options
    from wsbuild.verbs.metas import BUILD_KEYS

    declared = dict(declared_options(plugins=False))
    for name in BUILTIN:
        assert tuple(getattr(get_build_type(name), "options", ())) == declared.get(name, ())
    lists = {option.flag[2:] for options in declared.values() for option in options
             if option.kind == "arguments" and option.flag}
    assert set(BUILD_KEYS) == lists


def test_a_plan_asks_the_built_in_types_what_counts_without_importing_them() -> None:
    """`type_key_options` answers for a built-in type as the type itself does (what of the
    options enters a package's record), from the options it declares: a no-op plan imports
    none of the types' steps. Options given to every type, its own among them, count alike."""
    from dataclasses import replace

    from wsbuild.build_types import BuildOptions, type_key_options, type_options

    plain = BuildOptions()
    given = replace(plain, symlink_install=True, jobs=3).with_values(
        {"cmake_args": ["-DX=1"], "cmake_target": "all", "cmake_clean_cache": True})
    for name in BUILTIN:
        build_type = get_build_type(name)
        assert type_options(name) == tuple(build_type.options)
        for options in (plain, given, given.with_values({"ament_cmake_args": ["-DY=2"]})):
            assert type_key_options(name, options) == build_type.key_options(options), name
    # what a type declares reaches its key, what only changes how it runs does not
    assert type_key_options("cmake", given) != type_key_options("cmake", plain)
    assert type_key_options("cmake", replace(plain, jobs=7)) == type_key_options("cmake", plain)


def test_a_build_type_is_opened_and_closed_once_for_each_run_that_builds_its_packages(
        tmp_path: Path) -> None:
    """The per-run hooks of the protocol (`open_run`, `close_run`): a type holds what a run
    starts for it (the Python types' warm helpers) and wsbuild stops it, without reaching
    into the type's modules."""
    calls = tmp_path / "calls.txt"
    env = {**os.environ, "PYTHONPATH": str(_map_distribution(tmp_path / "plugins")),
           "WSB_MAP_RUN_LOG": str(calls)}
    ws = tmp_path / "ws"
    _map_workspace(ws)
    built = run_wsbuild("build", cwd=ws, env=env)
    assert built.returncode == 0, built.stdout + built.stderr
    assert calls.read_text() == "open\nclose\n"
    again = run_wsbuild("build", cwd=ws, env=env)  # nothing to build: nothing to open
    assert again.returncode == 0 and calls.read_text() == "open\nclose\n", again.stdout


def test_the_build_type_protocol_lists_exactly_what_wsbuild_calls() -> None:
    """Every attribute wsbuild takes of a loaded build type (`get_build_type(...).x`, or of
    a name bound to it) is in the `BuildType` protocol, and the protocol is what a plugin is
    checked against when it loads (`_REQUIRED`)."""
    import ast

    from wsbuild import build_types

    protocol = [name for name in build_types.BuildType.__annotations__] + [
        name for name, value in vars(build_types.BuildType).items()
        if callable(value) and not name.startswith("_")]
    assert sorted(protocol) == sorted(build_types._REQUIRED)
    used: dict[str, set[str]] = {}
    for path in sorted(Path(build_types.__file__).parent.parent.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for function in ast.walk(tree):
            if not isinstance(function, (ast.FunctionDef, ast.Module)):
                continue
            bound = {target.id for node in ast.walk(function) if isinstance(node, ast.Assign)
                     and isinstance(node.value, ast.Call)
                     and getattr(node.value.func, "id", "") == "get_build_type"
                     for target in node.targets if isinstance(target, ast.Name)}
            for node in ast.walk(function):
                if not isinstance(node, ast.Attribute):
                    continue
                value = node.value
                if (isinstance(value, ast.Call) and getattr(value.func, "id", "")
                        == "get_build_type") or (isinstance(value, ast.Name)
                                                 and value.id in bound):
                    used.setdefault(node.attr, set()).add(path.name)
    assert used and set(used) <= set(protocol), {a: used[a] for a in set(used) - set(protocol)}


def test_the_documented_example_installs_with_pip_and_builds_its_package(tmp_path: Path) -> None:
    """docs/examples/wsb_map is a distribution as its README says: pip installs it, and the
    build type it registers builds a package."""
    import shutil
    import sys

    source, target = tmp_path / "wsb_map", tmp_path / "site"
    shutil.copytree(EXAMPLE, source)  # a build writes beside the sources: not into the repo
    installed = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
         "--target", str(target), str(source)], capture_output=True, text=True, timeout=300)
    assert installed.returncode == 0, installed.stdout + installed.stderr
    ws = tmp_path / "ws"
    _map_workspace(ws)
    built = run_wsbuild("build", "--map-resolution", "0.5", cwd=ws,
                        env={**os.environ, "PYTHONPATH": str(target)})
    assert built.returncode == 0, built.stdout + built.stderr
    assert (ws / "install" / "maps" / "share" / "maps" / "resolution.txt").read_text() == "0.5\n"


def test_a_plugin_identifies_packages_that_have_no_package_xml(tmp_path: Path) -> None:
    """A package identifier (group `wsbuild.package_identification`) recognises a directory
    without package.xml; its package builds with its build type, and a package.xml always
    wins over it. Edited, what it read is seen by the next plan."""
    env = {**os.environ, "PYTHONPATH": str(_map_distribution(tmp_path / "plugins")),
           "XDG_CACHE_HOME": str(tmp_path / "cache")}
    ws = tmp_path / "ws"
    (ws / "src" / "floor").mkdir(parents=True)
    (ws / "src" / "floor" / "map.yaml").write_text("name: floor_map\nresolution: 1\n")
    _map_workspace(ws)  # `maps`, with a package.xml (and a map.yaml of another name)
    (ws / "src" / "maps" / "map.yaml").write_text("name: not_this_one\n")
    listed = run_wsbuild("list", cwd=ws, env=env)
    assert listed.returncode == 0, listed.stdout + listed.stderr
    assert [line.split()[0] for line in listed.stdout.splitlines()] == ["floor_map", "maps"]
    built = run_wsbuild("build", "--map-resolution", "0.25", cwd=ws, env=env)
    assert built.returncode == 0, built.stdout + built.stderr
    assert (ws / "install" / "floor_map" / "share" / "floor_map" / "resolution.txt"
            ).read_text() == "0.25\n"
    # the plugins found were kept, private to the user
    [kept] = (tmp_path / "cache" / "wsbuild-observe" / "plugins").glob("*.json")
    assert "wsb_map_type:identify" in kept.read_text()
    assert stat.S_IMODE(kept.stat().st_mode) == 0o600
    (ws / "src" / "floor" / "map.yaml").write_text("name: renamed_map\n")
    again = run_wsbuild("list", cwd=ws, env=env)
    assert [line.split()[0] for line in again.stdout.splitlines()] == ["maps", "renamed_map"]


def test_a_package_identifier_that_fails_is_one_error_naming_it(tmp_path: Path) -> None:
    """A plugin's identifier that raises stops the run before anything is built: exit 2, the
    identifier and the directory named, install/ untouched."""
    plugins = _plugin_distribution(tmp_path / "plugins", "wsb_map", MAP_PLUGIN + (
        "\n\ndef broken(path, names):\n    raise RuntimeError('cannot read map.yaml')\n"))
    with (plugins / "wsb_map_type-0.1.dist-info" / "entry_points.txt").open("a") as handle:
        handle.write("[wsbuild.package_identification]\nwsb_map = wsb_map_type:broken\n")
    ws = tmp_path / "ws"
    (ws / "src" / "floor").mkdir(parents=True)
    (ws / "src" / "floor" / "map.yaml").write_text("name: floor_map\n")
    done = run_wsbuild("build", cwd=ws, env={**os.environ, "PYTHONPATH": str(plugins),
                                              "XDG_CACHE_HOME": str(tmp_path / "cache")})
    assert done.returncode == 2, done.stdout + done.stderr
    first = done.stderr.strip().splitlines()[0]
    assert "wsb_map_type.broken failed on" in first and "cannot read map.yaml" in first, \
        done.stderr
    assert not (ws / "install").exists()
