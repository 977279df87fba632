"""Shell completion: `wsbuild completion bash|zsh` prints argcomplete's code; Tab in a real bash
then completes verbs, options, package names of the workspace and executables for `run`."""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from conftest import run_wsbuild

BIN = Path(sys.executable).parent  # the virtualenv's bin/, holding the `wsbuild` command

# Tab in bash: the words so far, then the function `complete -F` registered for wsbuild
BASH_TAB = r"""
eval "$(wsbuild completion bash)"
tab() {
    COMP_LINE="$1"; COMP_POINT=${#COMP_LINE}; COMP_TYPE=9
    read -ra COMP_WORDS <<< "$COMP_LINE"
    if [[ "$COMP_LINE" == *" " ]]; then COMP_WORDS+=(""); fi
    COMP_CWORD=$(( ${#COMP_WORDS[@]} - 1 ))
    COMPREPLY=()
    "$(complete -p wsbuild | sed -E 's/.* -F ([^ ]+) .*/\1/')" wsbuild
    printf '%s\n' "${COMPREPLY[@]}"
}
tab "$LINE"
"""


def _env() -> dict[str, str]:
    return dict(os.environ, PATH=f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}")


def tab(line: str, cwd: Path, **env: str) -> list[str]:
    """What bash offers for `line` followed by Tab, in `cwd`."""
    result = subprocess.run(["bash", "-c", BASH_TAB], cwd=cwd,
                            env={**_env(), "LINE": line, **env},
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    return [word.strip() for word in result.stdout.splitlines() if word.strip()]


def words(offered: list[str]) -> list[str]:
    return [word for word in offered if not word.startswith("-")]


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from conftest import write_package

    ws = tmp_path_factory.mktemp("completion") / "ws"
    for name, deps in (("nav_core", []), ("nav_planner", ["nav_core"]), ("arm_driver", [])):
        write_package(ws / "src" / "group", name, "ament_python", deps)
    (ws / "src" / "ignored").mkdir()
    (ws / "src" / "ignored" / "COLCON_IGNORE").touch()
    write_package(ws / "src" / "ignored", "hidden_pkg", "ament_python")
    built = run_wsbuild("build", "--packages-select", "nav_core", cwd=ws)
    assert built.returncode == 0, built.stdout + built.stderr
    return ws


def test_the_bash_code_registers_a_completion_function(tmp_path: Path) -> None:
    result = subprocess.run(["bash", "-c", 'eval "$(wsbuild completion bash)" && complete -p '
                             "wsbuild"], cwd=tmp_path, env=_env(), capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("complete ") and result.stdout.rstrip().endswith(" wsbuild")


def test_tab_completes_verbs_and_options(workspace: Path) -> None:
    assert tab("wsbuild cl", workspace) == ["clean"]
    assert tab("wsbuild test-r", workspace) == ["test-result"]
    assert tab("wsbuild build --symlink", workspace) == ["--symlink-install"]
    assert words(tab("wsbuild pkg ", workspace)) == ["create"]
    assert "--packages-up-to" in tab("wsbuild list --packages-", workspace)


def test_tab_completes_the_workspaces_package_names(workspace: Path) -> None:
    everything = ["arm_driver", "nav_core", "nav_planner"]
    assert tab("wsbuild build --packages-select nav", workspace) == ["nav_core", "nav_planner"]
    assert tab("wsbuild build --packages-up-to nav_core a", workspace) == ["arm_driver"]
    # after a space, the options come too
    assert words(tab("wsbuild info ", workspace)) == everything
    # from anywhere inside the workspace, and with -C from outside
    assert words(tab("wsbuild clean --packages-select ", workspace / "src" / "group")) == (
        everything)
    outside = workspace.parent
    assert words(tab(f"wsbuild list -C {shlex.quote(str(workspace))} --packages-skip ",
                     outside)) == everything


def test_an_option_that_takes_values_completes_its_values_before_any_option(
        workspace: Path, tmp_path: Path) -> None:
    """`--packages-select <Tab>` offers the package names alone (the options once a `-` is
    typed); `--mixin`, `--event-handlers`, `--build-type` and `-DCMAKE_BUILD_TYPE=` complete
    their values."""
    assert tab("wsbuild build --packages-select ", workspace) == [
        "arm_driver", "nav_core", "nav_planner"]
    assert "--packages-skip" in tab("wsbuild build --packages-select nav_core --packages-",
                                    workspace)
    assert tab("wsbuild build --event-handlers console_dir", workspace) == [
        "console_direct+", "console_direct-"]
    assert tab("wsbuild pkg create x --build-type ament_", workspace) == [
        "ament_cmake", "ament_python"]
    assert tab("wsbuild build --cmake-args -DCMAKE_BUILD_TYPE=Rel", workspace) == [
        "Release", "RelWithDebInfo"]
    assert tab("wsbuild build --cmake-args -DCMAKE_BU", workspace) == ["-DCMAKE_BUILD_TYPE="]
    home = tmp_path / "colcon_home"
    (home / "mixin" / "default").mkdir(parents=True)
    (home / "mixin" / "default" / "build.mixin").write_text(
        '{"build": {"release": {"cmake-args": ["-DCMAKE_BUILD_TYPE=Release"]}, '
        '"rel-with-deb-info": {"cmake-args": ["-DCMAKE_BUILD_TYPE=RelWithDebInfo"]}}}')
    assert tab("wsbuild build --mixin rel", workspace, COLCON_HOME=str(home)) == [
        "rel-with-deb-info", "release"]


def test_tab_completes_the_executables_of_a_package_for_run(workspace: Path) -> None:
    assert tab("wsbuild run nav_core nav", workspace) == ["nav_core_main"]


def test_zsh_registers_the_same_completion(tmp_path: Path) -> None:
    zsh = shutil.which("zsh")
    assert zsh, "zsh is missing: scripts/setup.sh installs it"
    script = ('autoload -U compinit && compinit -u -d "$PWD/.zcompdump" && '
              'eval "$(wsbuild completion zsh)" && print -r -- "${_comps[wsbuild]}"')
    result = subprocess.run([zsh, "-f", "-c", script], cwd=tmp_path, env=_env(),
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "_python_argcomplete"


def test_an_unknown_shell_is_a_usage_error(tmp_path: Path) -> None:
    result = run_wsbuild("completion", "fish", cwd=tmp_path)
    assert result.returncode == 2
    assert "invalid choice: 'fish' (choose from 'bash', 'zsh')" in result.stderr


def test_the_crawl_reads_names_not_directories(make_workspace: Callable[..., Path]) -> None:
    from conftest import write_package
    from wsbuild.verbs.completion import workspace_package_names

    ws = make_workspace({})
    path = write_package(ws / "src", "dir_name", "ament_cmake")
    text = (path / "package.xml").read_text().replace("<name>dir_name</name>",
                                                      "<name>\n  real_name\n</name>")
    (path / "package.xml").write_text(text)
    assert workspace_package_names(ws) == ["real_name"]
