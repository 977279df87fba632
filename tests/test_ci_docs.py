"""The CI configurations of docs/ci.md work: each is read from the page and its commands run
here, each job of the matrix at once in a workspace of its own seen at one path
(tests/one_path.py) with a local cache of its own (a machine each), then the assembling job,
all against one nginx cache on loopback, with the variables the CI system sets (run ids, a
parallel job's index). Left out is what only the CI system does: the checkout (a workspace is
copied into `src/`) and installing wsbuild (GitHub's `Install wsbuild` step, the install lines
of GitLab's `before_script`; this checkout's wsbuild is on PATH)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import yaml

from conftest import REPO
from nginx_server import NginxServer, nginx  # noqa: F401 (fixture)
from one_path import run_at_path
from test_build_helpers import REQUIRES_ROS, clean_env, output, write_ament_python, write_cmake

pytestmark = [*REQUIRES_ROS, pytest.mark.slow]

CI_PAGE = REPO / "docs" / "ci.md"
#: the lines of GitLab's before_script that install things (the CI image's business)
INSTALLING = re.compile(r"^(apt-get |python3 -m venv |/opt/wsbuild/bin/pip )")

LIB = """\
cmake_minimum_required(VERSION 3.14)
project({name} CXX)
add_library({name} SHARED {name}.cpp)
install(TARGETS {name} LIBRARY DESTINATION lib)
"""
TEST = "from {name}.value import NAME\n\n\ndef test_name():\n    assert NAME == {name!r}\n"
PACKAGES = ("ci_app", "ci_core", "ci_ext", "ci_tools")


def configuration(heading: str) -> dict[str, object]:
    """The first YAML block under `## heading` of docs/ci.md."""
    text = CI_PAGE.read_text(encoding="utf-8")
    section = text.split(f"\n## {heading}\n", 1)[1]
    block = re.search(r"```yaml\n(.*?)```", section, re.DOTALL)
    assert block is not None, f"no yaml block under {heading}"
    return yaml.safe_load(block.group(1))


def write_workspace(src: Path) -> None:
    write_cmake(src, "ci_core", LIB.format(name="ci_core"),
                files={"ci_core.cpp": "int ci_core() { return 1; }\n"})
    write_cmake(src, "ci_ext", LIB.format(name="ci_ext"), depend=["ci_core"],
                files={"ci_ext.cpp": "int ci_ext() { return 2; }\n"})
    for name, depend in (("ci_app", ["ci_core"]), ("ci_tools", [])):
        write_ament_python(src, name, modules={"value.py": f"NAME = {name!r}\n"},
                           depend=depend, data={"test/test_name.py": TEST.format(name=name)})


def run_job(workspace: Path, path: Path, script: str, env: Mapping[str, str],
            cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """A job's script in bash -e (as both CI systems run it), in `workspace` seen at `path`."""
    shutil.rmtree(workspace, ignore_errors=True)
    shutil.copytree(REPO_TEMPLATE[0], workspace / "src")
    start = f"cd {cwd}\n" if cwd is not None else ""
    return run_at_path(workspace, path, ["bash", "-e", "-c", start + script], env=env)


#: the workspace every job checks out (set by the fixture)
REPO_TEMPLATE: list[Path] = []


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    src = tmp_path_factory.mktemp("ci_template") / "src"
    write_workspace(src)
    REPO_TEMPLATE[:] = [src]
    return src


def machine_env(home: Path, machine: str, variables: Mapping[str, str]) -> dict[str, str]:
    """A CI machine: this checkout's wsbuild on PATH, a local cache of its own, `variables`."""
    env = clean_env(WSBUILD_CACHE_DIR=str(home / "machines" / machine))
    env.pop("WSBUILD_CACHE", None)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env['PATH']}"
    env.update(variables)
    return env


def run_matrix(jobs: Sequence[tuple[Path, str, dict[str, str], Path | None]], path: Path
               ) -> list[subprocess.CompletedProcess[str]]:
    """The jobs at once, as the CI system starts a matrix."""
    with ThreadPoolExecutor(max_workers=len(jobs)) as pool:
        futures = [pool.submit(run_job, workspace, path, script, env, cwd)
                   for workspace, script, env, cwd in jobs]
        return [future.result() for future in futures]


def restored(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith("Restored <<< "))


def test_the_github_actions_configuration_runs(template: Path, nginx: NginxServer,
                                               tmp_path: Path) -> None:
    workflow = configuration("GitHub Actions")
    jobs = workflow["jobs"]  # type: ignore[index]
    build, assemble = jobs["build"], jobs["assemble"]
    assert assemble["needs"] == "build"
    shards = build["strategy"]["matrix"]["shard"]
    assert shards == [1, 2, 3]

    def script(job: Mapping[str, object], shard: int | None = None) -> str:
        steps = job["steps"]  # type: ignore[union-attr]
        left_out = [s.get("name") or s["uses"] for s in steps
                    if "run" not in s or s.get("name") == "Install wsbuild"]
        assert all(name == "Install wsbuild" or name.startswith(("actions/checkout",
                                                                 "actions/upload-artifact"))
                   for name in left_out), left_out
        lines = [s["run"] for s in steps if "run" in s and s.get("name") != "Install wsbuild"]
        text = "\n".join(lines).replace("${{ matrix.shard }}", str(shard))
        assert "${{" not in text, text
        return text

    variables = {name: str(value).replace("${{ vars.WSBUILD_CACHE }}", nginx.url)
                 for name, value in workflow["env"].items()}  # type: ignore[union-attr]
    assert variables["WSBUILD_CACHE"] == nginx.url
    run = {"GITHUB_RUN_ID": "4711", "GITHUB_RUN_ATTEMPT": "1", "GITHUB_ACTIONS": "true"}
    path = tmp_path / "work" / "repo"
    path.mkdir(parents=True)
    matrix = run_matrix([(tmp_path / f"job{k}", script(build, k),
                          machine_env(tmp_path, f"m{k}", {**variables, **run,
                                                          "GITHUB_JOB": "build"}), None)
                         for k in shards], path)
    for k, done in zip(shards, matrix):
        assert done.returncode == 0, output(done)
        assert f"shard {k}/3: testing" in done.stderr, output(done)
    done = run_job(tmp_path / "assemble", path, script(assemble),
                   machine_env(tmp_path, "m4", {**variables, **run, "GITHUB_JOB": "assemble"}))
    assert done.returncode == 0, output(done)
    # every package comes from the cache: the jobs' entries are keyed alike
    assert restored(done) == sorted(PACKAGES), output(done)
    assert "every one built and tested by one of the 3 shards" in done.stdout, output(done)
    assert (tmp_path / "assemble" / "install.tar.gz").is_file()


def test_the_gitlab_ci_configuration_runs(template: Path, nginx: NginxServer,
                                          tmp_path: Path) -> None:
    config = configuration("GitLab CI")
    build, assemble = config["build"], config["assemble"]  # type: ignore[index]
    assert assemble["needs"] == ["build"]
    total = build["parallel"]
    before = [line for line in config["default"]["before_script"]  # type: ignore[index]
              if not INSTALLING.match(line)]
    assert len(before) == 2, before  # PATH and the workspace's directory

    builds_dir = tmp_path / "builds"
    path = builds_dir / "ws"
    path.mkdir(parents=True)
    pipeline = {"CI": "true", "GITLAB_CI": "true", "CI_PIPELINE_ID": "815",
                "CI_BUILDS_DIR": str(builds_dir), "WSBUILD_CACHE_URL": nginx.url}
    variables = {name: os.path.expandvars(str(value)) for name, value in
                 config["variables"].items()}  # type: ignore[union-attr]

    def expanded(value: str, env: Mapping[str, str]) -> str:
        return re.sub(r"\$(\w+)|\$\{(\w+)\}",
                      lambda m: env.get(m.group(1) or m.group(2), m.group(0)), value)

    def environment(machine: str, job: Mapping[str, str]) -> dict[str, str]:
        env = {**pipeline, **job}
        env.update({name: expanded(value, env) for name, value in
                    config["variables"].items()})  # type: ignore[union-attr]
        return machine_env(tmp_path, machine, env)

    def checked(env: Mapping[str, str]) -> Mapping[str, str]:
        assert env["WSBUILD_CACHE"] == nginx.url
        assert env["GIT_CLONE_PATH"] == str(path / "src")  # the checkout is the workspace's src/
        return env

    del variables
    jobs = []
    for k in range(1, total + 1):
        env = checked(environment(f"m{k}", {"CI_NODE_INDEX": str(k),
                                            "CI_NODE_TOTAL": str(total),
                                            "CI_JOB_NAME": f"build {k}/{total}",
                                            "CI_PROJECT_DIR": str(path / "src")}))
        jobs.append((tmp_path / f"job{k}", "\n".join([*before, *build["script"]]), env, None))
    for k, done in enumerate(run_matrix(jobs, path), start=1):
        assert done.returncode == 0, output(done)
        assert f"shard {k}/{total}: testing" in done.stderr, output(done)
    env = checked(environment("m9", {"CI_JOB_NAME": "assemble",
                                     "CI_PROJECT_DIR": str(path / "src")}))
    done = run_job(tmp_path / "assemble", path, "\n".join([*before, *assemble["script"]]), env)
    assert done.returncode == 0, output(done)
    assert restored(done) == sorted(PACKAGES), output(done)
    assert f"every one built and tested by one of the {total} shards" in done.stdout, \
        output(done)
    for artifact in assemble["artifacts"]["paths"]:
        assert (tmp_path / "assemble" / "src" / artifact).is_file(), artifact
