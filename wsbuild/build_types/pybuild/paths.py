"""Where Python files go inside an install prefix, as the building interpreter sees it."""

from __future__ import annotations

import sys
import sysconfig
from functools import lru_cache
from pathlib import PurePosixPath


@lru_cache(maxsize=None)
def site_packages_relpath(executable: str | None = None) -> PurePosixPath:
    """`lib/pythonX.Y/site-packages` (or the distribution's variant), relative to a prefix.

    colcon uses the same relative path, so overlays built by either tool agree.
    """
    if executable not in (None, sys.executable):
        # A different interpreter: assume the CPython default layout of its version.
        version = f"{sys.version_info.major}.{sys.version_info.minor}"
        return PurePosixPath("lib", f"python{version}", "site-packages")
    marker = "/__prefix__"
    path = sysconfig.get_path("purelib", vars={"base": marker, "platbase": marker})
    if "posix_local" in sysconfig.get_scheme_names() and "/local/" in path:
        # Debian's python adds /local/; colcon strips it too
        path = path.replace("/local/", "/", 1)
    return PurePosixPath(path).relative_to(marker)
