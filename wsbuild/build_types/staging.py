"""An install staged for any build type whose install command writes into the prefix it was
configured with (`cmake --install`, `meson install`): the steps around that command that put
the new install into the package's stage (prefix/stage.py), so that a failure leaves the
previous install in place. Public: a plugin's build type stages as the CMake types do.

- isolated install (a prefix of its own): park the previous install aside, run the install,
  move the new one into the stage and put the previous one back (a failure puts it back too);
- merged install (one shared prefix, which cannot be swapped): install through DESTDIR, then
  take what it wrote into the stage;
- merged, installing in place (ament's symlink install ignores DESTDIR): run it, then keep the
  list of files it wrote (`in_place`) in `ctx.outputs.installed_in_place`."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path

from wsbuild.build_types import Command, PackageContext, Step


def staged_install_steps(ctx: PackageContext, install: Command, *, reads: Sequence[Path] = (),
                         in_place: Callable[[PackageContext], Sequence[str]] | None = None
                         ) -> list[Step]:
    """The steps that run `install` (into `ctx.install_prefix`) and stage what it wrote.
    `in_place`: the type's install writes in place even in a merged prefix (it ignores
    DESTDIR); called after it, it names what it wrote, relative to the prefix."""
    prefix = ctx.install_prefix
    reads = tuple(reads)
    if ctx.options.merge_install and in_place is None:
        destdir = destdir_of(ctx)
        return [
            Step("clear destdir", clear_destdir,
                 description="remove what an earlier install left in DESTDIR", writes=(destdir,)),
            Step("install", command=Command(install.argv, install.cwd, env=install.env,
                                            run_env={**install.run_env,
                                                     "DESTDIR": str(destdir)},
                                            problems=install.problems),
                 reads=reads, writes=(destdir,)),
            Step("stage", take_destdir,
                 description="move what the install put into DESTDIR into the stage",
                 reads=(destdir,))]
    step = Step("install", command=install, reads=reads, writes=(prefix,))
    if ctx.options.merge_install:
        assert in_place is not None
        # written in place, as with colcon: the merged record keeps (and later prunes) it
        return [step, Step("keep manifest", _KeepInPlace(in_place),
                           description="keep the install manifests' list of files",
                           reads=reads)]
    return [
        Step("park install", park_install,
             description="park the previous install aside (a failure puts it back)",
             writes=(prefix,)),
        step,
        Step("stage", stage_direct_install,
             description="move the new install into the stage, put the previous one back",
             reads=(prefix,), writes=(prefix,))]


class _KeepInPlace:
    """The `keep manifest` step: what an in-place install wrote, as the build type lists it
    (a class, so that two decisions of the step compare equal)."""

    __slots__ = ("listed",)

    def __init__(self, listed: Callable[[PackageContext], Sequence[str]]) -> None:
        self.listed = listed

    def __call__(self, ctx: PackageContext) -> None:
        ctx.outputs.installed_in_place = tuple(self.listed(ctx))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _KeepInPlace) and other.listed == self.listed

    def __hash__(self) -> int:
        return hash(self.listed)


def destdir_of(ctx: PackageContext) -> Path:
    """Where a merged install stages through DESTDIR."""
    return ctx.build_dir / ".wsbuild" / "destdir"


def clear_destdir(ctx: PackageContext) -> None:
    if destdir_of(ctx).exists():
        shutil.rmtree(destdir_of(ctx))


def take_destdir(ctx: PackageContext) -> None:
    destdir = destdir_of(ctx)
    staged = destdir / str(ctx.install_prefix).lstrip(os.sep)
    if staged.exists():
        shutil.rmtree(ctx.stage_prefix)
        os.rename(staged, ctx.stage_prefix)
    shutil.rmtree(destdir, ignore_errors=True)


def park_install(ctx: PackageContext) -> None:
    """Before an install that writes straight into the final prefix: the previous install
    aside, a fresh prefix (prefix/stage.py)."""
    from wsbuild.prefix.stage import park_previous_install  # lazy: off `build --dry-run` and `test`

    park_previous_install(ctx.install_prefix, ctx.stage_prefix)


def stage_direct_install(ctx: PackageContext) -> None:
    """After it: the new install into the stage, the previous one back."""
    from wsbuild.prefix.stage import stage_direct_install as stage  # lazy: off `build --dry-run`

    stage(ctx.install_prefix, ctx.stage_prefix)
