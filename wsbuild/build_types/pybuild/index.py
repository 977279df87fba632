"""The ament index marker and package.xml of a Python package, installed when its setup.py
forgets them (the `index` step ament_python adds to the python recipe): like colcon-ros, with
a warning that says what to add to `data_files`."""

from __future__ import annotations

from pathlib import PurePosixPath

from wsbuild.build_types import PackageContext, StepFailed
from wsbuild.build_types.pybuild.install import StageWriter
from wsbuild.build_types.pybuild.recipe import origin_file

INDEX_DIR = PurePosixPath("share/ament_index/resource_index/packages")


def register(ctx: PackageContext) -> None:
    """Install the ament index marker and package.xml if setup.py did not."""
    name = ctx.package.name
    writer = StageWriter(ctx.stage_prefix)
    origin = origin_file(ctx.source_dir).name
    marker = INDEX_DIR / name
    if not _installed(ctx, marker):
        writer.write(marker, b"")
        ctx.warn(f"{origin} does not install the ament index marker; wsbuild installed "
                 f"{marker} anyway. Create an empty file resource/{name} and add "
                 f"('{INDEX_DIR}', ['resource/{name}']) to data_files in {origin}")
    manifest = PurePosixPath("share", name, "package.xml")
    if not _installed(ctx, manifest):
        source = (ctx.package.manifest or ctx.source_dir / "package.xml").absolute()
        if not source.is_file():
            raise StepFailed(f"{ctx.source_dir}: no package.xml to install")
        if ctx.options.symlink_install:
            writer.symlink(source, manifest)
        else:
            writer.copy(source, manifest)
        ctx.warn(f"{origin} does not install package.xml; wsbuild installed {manifest} "
                 f"anyway. Add ('share/{name}', ['package.xml']) to data_files in {origin}")


def _installed(ctx: PackageContext, relpath: PurePosixPath) -> bool:
    path = ctx.stage_prefix / relpath
    return path.is_symlink() or path.exists()
