"""What `pkg create` uses when an option is not given: the destination (the workspace's src/)
and the maintainer (git's user.name and user.email, else the login name)."""

from __future__ import annotations

import getpass
import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

from wsbuild.create.validation import CONTROL_CHARACTER, EMAIL
from wsbuild.workspace.root import find_workspace_root


@dataclass(frozen=True, slots=True)
class Maintainer:
    """The maintainer a new package names (from the options or git's config)."""

    name: str
    email: str
    #: set when a value had to be made up (no git config): tells the user how to fix it
    note: str | None = None


def default_destination(cwd: Path) -> Path:
    """Where a new package goes: the workspace's src/, or the current directory when that is
    already inside src/ (beside the package when it is inside one); without a workspace, the
    current directory."""
    cwd = Path(os.path.abspath(cwd))
    root = find_workspace_root(cwd)
    src = root / "src"
    if not src.is_dir():
        return cwd
    if cwd != src and src not in cwd.parents:
        return src
    destination = cwd
    for directory in (cwd, *cwd.parents):
        if directory == src:
            break
        if (directory / "package.xml").is_file():
            destination = directory.parent  # packages inside packages are never found
    return destination


def default_maintainer(cwd: Path) -> Maintainer:
    """From `git config user.name/user.email` (as seen from `cwd`), else the login name."""
    login = _login_name()
    name = _git_config("user.name", cwd) or login
    email = _git_config("user.email", cwd)
    if email and EMAIL.fullmatch(email):
        return Maintainer(name, email)
    email = f"{re.sub(r'[^A-Za-z0-9._-]', '_', login)}@todo.todo"
    return Maintainer(name, email, note=f"maintainer email unknown, wrote {email}: pass "
                                        "--maintainer-email or set git config user.email")


def _login_name() -> str:
    try:
        return getpass.getuser() or "maintainer"
    except (OSError, KeyError):
        return "maintainer"


def _git_config(key: str, cwd: Path) -> str | None:
    git = shutil.which("git")
    if git is None:
        return None
    directory = cwd if cwd.is_dir() else Path.cwd()
    try:
        result = subprocess.run([git, "config", "--get", key], cwd=directory, capture_output=True,
                                text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    value = result.stdout.strip() if result.returncode == 0 else ""
    return value if value and not CONTROL_CHARACTER.search(value) else None
