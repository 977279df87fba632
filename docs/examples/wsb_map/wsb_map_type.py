"""wsb_map: an example of a third-party build type (docs/examples/wsb_map/README.md).

Packages whose package.xml says `<build_type>wsb_map</build_type>`, and directories holding a
`map.yaml` that names them (`identify`: no package.xml needed), get a map resolution file
installed, written by an in-process step from an option of the type's own
(`wsbuild build --map-resolution 0.05`). tests/test_build_type_plugin.py builds with this very
module, so what it shows is what works.
"""
from dataclasses import dataclass

from wsbuild.build_types import BuildTypeBase, Command, Step, TypeOption

#: an option of `wsbuild build` of this type's own: shown under "wsb_map packages:" in
#: `wsbuild build --help`, read by defaults files (`map-resolution:`), and part of each
#: package's key (`in_key`, the default): another value rebuilds its packages
RESOLUTION = TypeOption("--map-resolution", "map_resolution", metavar="METRES",
                        help="the resolution the installed maps are made for")

#: what the step writes, by hand as in wsbuild
SCRIPT = 'mkdir -p -- "$(dirname -- "$1")" && printf "%s\\n" "$2" > "$1"'


def write_resolution(ctx):
    """The step's action: it runs in wsbuild's process with the build's context, and writes
    into the stage (`ctx.stage_prefix`), which wsbuild commits into install/ when every step
    succeeded. It computes what it writes from `ctx` alone (no value bound when the plan was
    made), so the build and its plan agree step for step."""
    target = ctx.stage_prefix / "share" / ctx.package.name / "resolution.txt"
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(f"{ctx.options.value(RESOLUTION) or 'unset'}\n")


@dataclass(frozen=True, slots=True)
class MapBuildType(BuildTypeBase):
    """BuildTypeBase gives every part of the `BuildType` protocol a default (no tests, plain
    environment hooks, nothing read outside, nothing to open per run); a type sets its `name`
    (the entry point's) and its `steps`, and overrides what differs."""

    name: str = "wsb_map"
    options: tuple = (RESOLUTION,)

    def steps(self, ctx):
        """The package's steps as data, decided from the context alone (read nothing, run
        nothing here): `--dry-run` prints them, the build runs them. A command step is
        `Step(label, command=Command(argv, cwd))`; this one is in-process, with the command
        that does the same by hand (printed by `--dry-run --commands`, and in the reproduce
        script if it fails)."""
        value = ctx.options.value(RESOLUTION) or "unset"
        target = ctx.install_prefix / "share" / ctx.package.name / "resolution.txt"
        return [Step("resolution", write_resolution,
                     description=f"write the map resolution {value}", writes=(target,),
                     by_hand=Command(("sh", "-c", SCRIPT, "sh", str(target), value),
                                     ctx.source_dir))]

    def open_run(self, environ):
        """Once per run that builds a package of this type, before the first: where a type
        starts what its packages share (a server, a warm helper). This one only notes the
        call in the file WSB_MAP_RUN_LOG names, if any."""
        _run_log("open")

    def close_run(self):
        """Once after the run's last package: stop what `open_run` (or a step) started."""
        _run_log("close")


def _run_log(what):
    import os

    path = os.environ.get("WSB_MAP_RUN_LOG")
    if path:
        with open(path, "a") as handle:
            handle.write(what + "\n")


#: what the entry point names (pyproject.toml)
BUILD_TYPE = MapBuildType()


def identify(path, names):
    """A package without package.xml: a directory holding `map.yaml` whose first line is
    `name: <package>` (the entry point of group `wsbuild.package_identification`). Called for
    each directory of the workspace that none of wsbuild's own rules takes, with the names in
    it; reads through wsbuild.inputs, as every read of a run that plans does."""
    from wsbuild import inputs
    from wsbuild.workspace.model import Package

    if "map.yaml" not in names or "package.xml" in names:
        return None
    first = inputs.read_text(path / "map.yaml").partition("\n")[0]
    key, _, name = first.partition(":")
    if key.strip() != "name" or not name.strip():
        return None
    return Package(name=name.strip(), path=path, build_type="wsb_map")
