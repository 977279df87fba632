"""No secret reaches a file wsbuild writes: the credentials of a URL (the cache's, one a build
step prints), a secret in the environment (one a build step prints too), the password in
~/.netrc wsbuild sends to the cache (wsbuild/redaction.py); one writer writes every package's
command.log."""

from __future__ import annotations

import base64
import os
from pathlib import Path

from nginx_server import NginxServer, nginx  # noqa: F401 (fixture)
from test_build_helpers import clean_env, output, write_cmake, wsbuild
from wsbuild.redaction import redact, redact_bytes

PRINTS_ITS_REMOTE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
message(STATUS "fetching from $ENV{{VENDOR_REPOSITORY}}")
message(STATUS "with the token $ENV{{API_TOKEN}}")
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


def test_secret_names_and_known_values_are_hidden() -> None:
    from wsbuild.redaction import remember, secret_name

    for name in ("API_TOKEN", "GITHUB_TOKEN", "AWS_SECRET_ACCESS_KEY", "DB_PASSWORD",
                 "NPM_PASSWD", "GITHUB_PAT", "MY_API_KEY", "GOOGLE_CREDENTIALS"):
        assert secret_name(name), name
    for name in ("PATH", "GIT_AUTHOR_NAME", "AMENT_PREFIX_PATH", "KEYBOARD", "ROS_DOMAIN_ID",
                 "TOKENIZERS_PARALLELISM"):
        assert not secret_name(name), name
    remember(["short", "wsbuild-known-secret-value"])
    assert redact("token=wsbuild-known-secret-value, short") == "token=***, short"
    assert redact_bytes(b"x wsbuild-known-secret-value\n") == b"x ***\n"


def _written(ws: Path, secrets: dict[str, str]) -> list[str]:
    """Which secret is in which file under build/, log/ and install/."""
    found = []
    for top in ("build", "log", "install"):
        for path in (ws / top).rglob("*"):
            if path.is_file() and not path.is_symlink():
                data = path.read_bytes()
                found += [f"{path.relative_to(ws)}: {name}" for name, secret in secrets.items()
                          if secret.encode() in data]
    return found


def test_no_secret_is_written_under_build_log_or_install(tmp_path: Path,
                                                          nginx: NginxServer) -> None:
    """The credentials of the cache's URL, of a URL a step prints, a secret of the environment
    (a step prints it too), and the `~/.netrc` password wsbuild sends to the cache server
    (which it does: the server's log shows it) are in no file under build/, log/ or
    install/; the lines that held them are kept, the secrets replaced by `***`."""
    pid = os.getpid()
    secrets = {name: f"wsbuild-secret-{name}-{pid}" for name in
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
    basic = base64.b64encode(f"ci:{secrets['netrc']}".encode()).decode()
    secrets["netrc, as sent"] = basic
    env = clean_env(HOME=str(home), API_TOKEN=secrets["environment"], XDG_CACHE_HOME=str(home),
                    VENDOR_REPOSITORY=f"https://ci:{secrets['repository']}@127.0.0.1:9/v.git")
    env.pop("WSBUILD_CACHE_DIR", None)
    env.pop("WSBUILD_CACHE_TOKEN", None)

    # the cache's URL has no credentials: they come from ~/.netrc
    built = wsbuild("build", "--continue-on-error", "--cache", nginx.url, cwd=ws, env=env)
    assert built.returncode == 1, output(built)  # `broken` fails, quoting the URL
    assert any(line.endswith(f"auth=Basic {basic}") for line in nginx.requests(at_least=1))
    with_url = f"http://ci:{secrets['cache']}@127.0.0.1:9/"
    again = wsbuild("build", "--continue-on-error", "--cache", with_url, cwd=ws, env=env)
    assert again.returncode == 1, output(again)
    tested = wsbuild("test", "--packages-select", "fine", cwd=ws, env=env)
    assert tested.returncode == 0, output(tested)

    first = sorted(p for p in (ws / "log").iterdir() if p.name.startswith("build_"))[0]
    logs = (first / "fine" / "stdout_stderr.log").read_text()
    assert "fetching from https://***@127.0.0.1:9/v.git" in logs  # the line is kept
    assert "token ***" in logs  # the secret of the environment the step printed
    assert _written(ws, secrets) == []
    assert not [line for line in (built.stdout + built.stderr + again.stdout + again.stderr)
                .splitlines() if any(secret in line for secret in secrets.values())]


def test_every_command_log_is_written_by_the_one_writer() -> None:
    """No module but engine/logs.py names the file: a new writer cannot skip the redaction."""
    import ast

    from conftest import REPO

    naming = []
    for path in sorted((REPO / "wsbuild").rglob("*.py")):
        tree = ast.parse(path.read_text())
        docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                      if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef,
                                           ast.AsyncFunctionDef))
                      and node.body and isinstance(node.body[0], ast.Expr)}
        naming += [f"{path.relative_to(REPO)}:{node.lineno}" for node in ast.walk(tree)
                   if isinstance(node, ast.Constant) and isinstance(node.value, str)
                   and "command.log" in node.value and id(node) not in docstrings
                   and not path.match("engine/logs.py") and not path.match("verbs/colcon.py")]
    assert naming == []
