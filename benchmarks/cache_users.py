"""Two users, one checkout path, one shared cache: how many packages the second user's fresh
clone restores from what the first one built (issue 36: a package's record covers every
environment variable, and the variables that differ between users and machines, `SHARED` in
wsbuild/record/environment.py, stay out of the key a cache entry is found by).

    .venv/bin/python benchmarks/cache_users.py            # mixed 36-package workspace
    .venv/bin/python benchmarks/cache_users.py --quick    # 8 packages

Each user is a real account made for the run (`useradd`, as root; `--same-account` instead
runs both as the caller with their HOME, USER and LOGNAME changed), with a home and a local
cache of its own, building with `wsbuild build --cache URL` against one nginx (WebDAV) server
on loopback. The first user builds the workspace at /tmp/wsbuild-bench-shared/ws; the
directory is removed and the second user checks the same sources out at the same path and
builds. The result: packages restored / packages, and what each restore said differed.
"""

from __future__ import annotations

import argparse
import os
import pwd
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.generate import WorkspaceSpec, generate_workspace
from benchmarks.tools import DEFAULT_PROJECT_VENV, REPO, clean_environ, write_section

sys.path.insert(0, str(REPO / "tests"))
from nginx_server import NginxServer  # noqa: E402  (the tests' nginx fixture, reused)

DOCS = REPO / "docs" / "benchmarks.md"
BEGIN = "<!-- cache_users.py: begin -->"
END = "<!-- cache_users.py: end -->"
SHARED_PATH = Path("/tmp/wsbuild-bench-shared/ws")
USERS = ("wsbalice", "wsbbob")


def _account(name: str, same_account: bool, homes: Path) -> tuple[list[str], dict[str, str]]:
    """The command prefix that runs as `name`, and its environment's own variables."""
    if same_account:
        home = homes / name
        home.mkdir(parents=True, exist_ok=True)
        return [], {"HOME": str(home), "USER": name, "LOGNAME": name}
    try:
        pwd.getpwnam(name)
    except KeyError:
        subprocess.run(["useradd", "--create-home", "--shell", "/bin/bash", name], check=True)
    home = pwd.getpwnam(name).pw_dir
    python = DEFAULT_PROJECT_VENV / "bin" / "python"
    if subprocess.run(["runuser", "-u", name, "--", str(python), "-c", "pass"],
                      capture_output=True, check=False).returncode != 0:
        raise PermissionError(f"{name} cannot run {python} (the interpreter's directories "
                              "are private)")
    return ["runuser", "-u", name, "--"], {"HOME": home, "USER": name, "LOGNAME": name}


def _build(prefix: list[str], env: dict[str, str], url: str) -> tuple[subprocess.CompletedProcess[str], float]:
    started = time.monotonic()
    done = subprocess.run([*prefix, "env", *[f"{k}={v}" for k, v in env.items()],
                           str(DEFAULT_PROJECT_VENV / "bin" / "wsbuild"), "build", "--cache", url],
                          cwd=SHARED_PATH, env=env, capture_output=True, text=True, timeout=3600)
    return done, time.monotonic() - started


def _checkout(template: Path, owner: str | None) -> None:
    shutil.rmtree(SHARED_PATH, ignore_errors=True)
    SHARED_PATH.mkdir(parents=True)
    shutil.copytree(template / "src", SHARED_PATH / "src", symlinks=True)
    if owner is not None:
        subprocess.run(["chown", "-R", f"{owner}:{owner}", str(SHARED_PATH)], check=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--same-account", action="store_true",
                        help="one account, HOME, USER and LOGNAME changed (no root needed)")
    parser.add_argument("--no-docs", action="store_true")
    args = parser.parse_args(argv)
    same = args.same_account or os.geteuid() != 0
    work = Path(tempfile.mkdtemp(prefix="wsbuild-cache-users-"))
    os.chmod(work, 0o755)
    spec = WorkspaceSpec(6, 2) if args.quick else WorkspaceSpec(30, 6)
    template = generate_workspace(work / "template", spec).root
    os.chmod(SHARED_PATH.parent if SHARED_PATH.parent.exists() else work, 0o755)
    SHARED_PATH.parent.mkdir(parents=True, exist_ok=True)
    os.chmod(SHARED_PATH.parent, 0o777)
    server = NginxServer(work / "nginx")
    server.start()
    try:
        results = []
        for number, name in enumerate(USERS):
            try:
                prefix, own = _account(name, same, work / "homes")
            except PermissionError as exc:
                print(f"{exc}: both users run as this account instead", file=sys.stderr)
                same = True
                prefix, own = _account(name, same, work / "homes")
            env = {**clean_environ(), **own}
            env.pop("WSBUILD_CACHE_DIR", None)
            env.pop("XDG_CACHE_HOME", None)
            _checkout(template, None if same else name)
            done, seconds = _build(prefix, env, server.url)
            if done.returncode != 0:
                print(done.stdout[-3000:], done.stderr[-3000:], file=sys.stderr)
                return 1
            restored = len(re.findall(r"^Restored <<< ", done.stdout, re.MULTILINE))
            built = len(re.findall(r"^Finished <<< ", done.stdout, re.MULTILINE))
            differed = sorted({m for path in (SHARED_PATH / "log" / "latest_build").glob(
                "*/command.log") for m in re.findall(r"built where (.*) differed",
                                                     path.read_text())})
            results.append((name, restored, built, seconds, differed))
        total = spec.total
        lines = [f"{name}: {restored} of {total} restored, {built} built, {seconds:.1f} s"
                 + (f" (restores said: built where {'; '.join(differed)} differed)"
                    if differed else "") for name, restored, built, seconds, differed in results]
        how = "one account, HOME/USER/LOGNAME changed" if same else "two accounts (useradd)"
        rate = results[1][1] / total
        summary = (f"second user's hit rate: {rate:.0%} ({results[1][1]} of {total} packages), "
                   f"{how}, checkout at {SHARED_PATH}, one nginx cache")
        print("\n".join([*lines, summary]))
        if not args.no_docs and not args.quick:
            stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
            section = "\n".join([BEGIN, "", f"`python benchmarks/cache_users.py`, {stamp}", "",
                                 *[f"- {line}" for line in lines], f"- {summary}", "", END, ""])
            write_section(DOCS, BEGIN, END, section)
        return 0
    finally:
        server.stop()
        shutil.rmtree(SHARED_PATH, ignore_errors=True)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
