"""The `cmake` build type: configure when needed, build, install. ament_cmake builds on it."""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from wsbuild.build_types import BuildContext, Step
from wsbuild.prefix.stage import direct_install

#: what the last configure used, to know when to configure again
CONFIGURE_RECORD = Path(".wsbuild") / "cmake_configure.json"
#: ctx.extra key: files (relative to the prefix) an install wrote into the prefix directly
INSTALLED_IN_PLACE = "cmake.installed_in_place"


def _manifest_files(ctx: BuildContext) -> list[str]:
    files: list[str] = []
    for name in ("install_manifest.txt", "symlink_install_manifest.txt"):
        path = ctx.build_dir / name
        if path.is_file():
            for line in path.read_text().splitlines():
                if line.strip() and Path(line).is_relative_to(ctx.install_prefix):
                    files.append(str(Path(line).relative_to(ctx.install_prefix)))
    return sorted(set(files))


@dataclass(frozen=True, slots=True)
class CMakeBuildType:
    name: str = "cmake"

    def steps(self, ctx: BuildContext) -> list[Step]:
        steps = []
        if self.needs_configure(ctx):
            steps.append(Step("configure", self.configure))
        steps.append(Step("build", self.build))
        steps.append(Step("install", self.install))
        return steps

    def configure_args(self, ctx: BuildContext) -> list[str]:
        python = ctx.options.python_executable
        args = [
            # wsbuild passes Python hints every project may ignore: don't warn about them
            "--no-warn-unused-cli",
            f"-DCMAKE_INSTALL_PREFIX={ctx.install_prefix}",
            "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON",
            f"-DPYTHON_EXECUTABLE={python}",
        ]
        if not any(a.startswith("-DPython3_EXECUTABLE=") for a in ctx.options.underlay_cmake_args):
            args.append(f"-DPython3_EXECUTABLE={python}")
        return [*args, *ctx.options.underlay_cmake_args, *ctx.options.cmake_args]

    def needs_configure(self, ctx: BuildContext) -> bool:
        cache = ctx.build_dir / "CMakeCache.txt"
        if ctx.options.cmake_clean_cache or ctx.options.cmake_force_configure:
            return True
        if not cache.exists():
            return True
        return self._record(ctx) != self._read_record(ctx)

    def _record(self, ctx: BuildContext) -> dict[str, object]:
        return {"source": str(ctx.source_dir), "args": self.configure_args(ctx)}

    def _read_record(self, ctx: BuildContext) -> object:
        try:
            return json.loads((ctx.build_dir / CONFIGURE_RECORD).read_text())
        except (OSError, ValueError):
            return None

    def configure(self, ctx: BuildContext) -> None:
        cache = ctx.build_dir / "CMakeCache.txt"
        if ctx.options.cmake_clean_cache and cache.exists():
            cache.unlink()
            shutil.rmtree(ctx.build_dir / "CMakeFiles", ignore_errors=True)
        record = ctx.build_dir / CONFIGURE_RECORD
        if record.exists():
            record.unlink()  # a failed configure must be retried next time
        ctx.run(["cmake", str(ctx.source_dir), *self.configure_args(ctx)], cwd=ctx.build_dir)
        record.parent.mkdir(parents=True, exist_ok=True)
        record.write_text(json.dumps(self._record(ctx), indent=1) + "\n")

    def build(self, ctx: BuildContext) -> None:
        command = ["cmake", "--build", str(ctx.build_dir)]
        if ctx.options.cmake_target:
            command += ["--target", ctx.options.cmake_target]
        if ctx.options.cmake_clean_first:
            command.append("--clean-first")
        ctx.run(command, cwd=ctx.build_dir)

    def installs_in_place(self, ctx: BuildContext) -> bool:
        """Whether `cmake --install` ignores DESTDIR (ament's symlink install); plain CMake
        has no symlink install and always stages."""
        return False

    def install(self, ctx: BuildContext) -> None:
        command = ["cmake", "--install", str(ctx.build_dir)]
        if ctx.options.merge_install and not self.installs_in_place(ctx):
            # the shared prefix cannot be swapped: stage through DESTDIR instead
            destdir = ctx.build_dir / ".wsbuild" / "destdir"
            if destdir.exists():
                shutil.rmtree(destdir)
            env = dict(ctx.environ, DESTDIR=str(destdir))
            ctx.run(command, cwd=ctx.build_dir, env=env)
            staged = destdir / str(ctx.install_prefix).lstrip(os.sep)
            if staged.exists():
                shutil.rmtree(ctx.stage_prefix)
                os.rename(staged, ctx.stage_prefix)
            shutil.rmtree(destdir, ignore_errors=True)
        elif ctx.options.merge_install:
            # symlink install into a merged prefix writes in place, as with colcon; the
            # manifests say what it wrote, so the merged record keeps (and later prunes) it
            ctx.run(command, cwd=ctx.build_dir)
            ctx.extra[INSTALLED_IN_PLACE] = tuple(_manifest_files(ctx))
        else:
            with direct_install(ctx.install_prefix, ctx.stage_prefix):
                ctx.run(command, cwd=ctx.build_dir)


BUILD_TYPE = CMakeBuildType()
