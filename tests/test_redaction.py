"""No secret reaches a file wsbuild writes: the credentials of a URL (the cache's, one a build
step prints), a secret in the environment, a token in ~/.netrc (wsbuild/redaction.py)."""

from __future__ import annotations

import os
from pathlib import Path

from test_build_helpers import clean_env, output, write_cmake, wsbuild
from wsbuild.redaction import redact, redact_bytes

PRINTS_ITS_REMOTE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
message(STATUS "fetching from $ENV{{VENDOR_REPOSITORY}}")
{fail}
install(FILES CMakeLists.txt DESTINATION share/${{PROJECT_NAME}})
"""


def test_credentials_of_a_url_are_hidden_and_nothing_else_changes() -> None:
    assert redact("wsbuild build --cache http://ci:pw@cache:8080/") == \
        "wsbuild build --cache http://***@cache:8080/"
    assert redact("git clone https://TOKEN@example.org/repo.git") == \
        "git clone https://***@example.org/repo.git"
    assert redact_bytes(b"--index-url https://u:p@pypi.example/simple\n") == \
        b"--index-url https://***@pypi.example/simple\n"
    for kept in ("git@github.com:ros2/ros2cli.git", "mail me at a@b.c", "http://host/a@b"):
        assert redact(kept) == kept


def test_no_secret_is_written_under_build_log_or_install(tmp_path: Path) -> None:
    secrets = {name: f"wsbuild-secret-{name}-{os.getpid()}" for name in
               ("cache", "repository", "environment", "netrc")}
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "fine", PRINTS_ITS_REMOTE.format(name="fine", fail=""))
    write_cmake(ws / "src", "broken", PRINTS_ITS_REMOTE.format(
        name="broken", fail='message(FATAL_ERROR "cannot fetch $ENV{VENDOR_REPOSITORY}")'))
    home = tmp_path / "home"
    home.mkdir()
    netrc = home / ".netrc"
    netrc.write_text(f"machine 127.0.0.1 login ci password {secrets['netrc']}\n")
    netrc.chmod(0o600)
    env = clean_env(HOME=str(home), API_TOKEN=secrets["environment"],
                    VENDOR_REPOSITORY=f"https://ci:{secrets['repository']}@127.0.0.1:9/v.git")
    cache = f"http://ci:{secrets['cache']}@127.0.0.1:9/"

    built = wsbuild("build", "--continue-on-error", "--cache", cache, cwd=ws, env=env)
    assert built.returncode == 1, output(built)  # `broken` fails, quoting the URL
    tested = wsbuild("test", "--packages-select", "fine", cwd=ws, env=env)
    assert tested.returncode == 0, output(tested)

    logs = (ws / "log" / "latest_build" / "fine" / "stdout_stderr.log").read_text()
    assert "fetching from https://***@127.0.0.1:9/v.git" in logs  # the line is kept
    found = []
    for top in ("build", "log", "install"):
        for path in (ws / top).rglob("*"):
            if path.is_file() and not path.is_symlink():
                data = path.read_bytes()
                found += [f"{path.relative_to(ws)}: {name}" for name, secret in secrets.items()
                          if secret.encode() in data]
    assert found == []
