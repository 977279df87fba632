"""Reading .dsv environment descriptions the way colcon's prefix_util does."""

from __future__ import annotations

from pathlib import Path

import pytest

from wsbuild.errors import WsbuildError
from wsbuild.prefix.dsv import Action, Operation, resolve_package


def package(tmp_path: Path, dsv: str, **files: str) -> Path:
    prefix = tmp_path / "pkg"
    share = prefix / "share" / "pkg"
    share.mkdir(parents=True)
    (share / "package.dsv").write_text(dsv)
    for name, content in files.items():
        path = prefix / name.replace("__", "/")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(content)
    return prefix


def operations(prefix: Path) -> list[Operation]:
    return list(resolve_package(prefix, "pkg").operations)


def test_sources_follow_dsv_siblings_after_the_plain_lines(tmp_path: Path) -> None:
    prefix = package(
        tmp_path,
        "source;share/pkg/hook/a.dsv\nsource;share/pkg/hook/a.sh\n"
        "# a comment\n\nset;FIRST;1\n",
        share__pkg__hook__a_dsv="prepend-non-duplicate;PATH;bin;sbin\n",
    )
    (prefix / "share/pkg/hook/a_dsv").rename(prefix / "share/pkg/hook/a.dsv")

    assert operations(prefix) == [
        Operation(Action.SET, "FIRST", "1", False),
        Operation(Action.PREPEND, "PATH", "bin", True),
        Operation(Action.PREPEND, "PATH", "sbin", True),
    ]


def test_script_without_dsv_becomes_a_source_operation(tmp_path: Path) -> None:
    prefix = package(tmp_path, "source;share/pkg/x.sh\nsource;share/pkg/x.bash\nsource;/abs/y.sh\n"
                     "source;share/pkg/z.bash\n")

    sources = operations(prefix)

    assert [(op.value, op.relative, op.extensions) for op in sources] == [
        ("share/pkg/x", True, ("bash", "sh")), ("/abs/y", False, ("sh",)), ("share/pkg/z", True, ("bash",))
    ]
    assert [op.script_for(None) for op in sources] == ["share/pkg/x.sh", "/abs/y.sh", None]
    assert [op.script_for("bash") for op in sources] == ["share/pkg/x.bash", "/abs/y.sh", "share/pkg/z.bash"]
    assert [op.script_for("zsh") for op in sources] == ["share/pkg/x.sh", "/abs/y.sh", None]


def test_existence_decides_relative_values(tmp_path: Path) -> None:
    prefix = package(
        tmp_path,
        "set;HERE;data\nset;LITERAL;nothing-here\nset;PREFIX;\nset;ABS;/etc\n"
        "prepend-non-duplicate-if-exists;PATH;bin;data;\n"
        "append-non-duplicate;LIST;missing;/abs\n",
        data__file="",
    )

    assert operations(prefix) == [
        Operation(Action.SET, "HERE", "data", True),
        Operation(Action.SET, "LITERAL", "nothing-here", False),
        Operation(Action.SET, "PREFIX", "", True),
        Operation(Action.SET, "ABS", "/etc", False),
        Operation(Action.PREPEND, "PATH", "data", True),
        Operation(Action.PREPEND, "PATH", "", True),
        Operation(Action.APPEND, "LIST", "missing", True),
        Operation(Action.APPEND, "LIST", "/abs", False),
    ]
    assert operations(prefix)[0].resolve("/p") == "/p/data"
    assert operations(prefix)[2].resolve("/p") == "/p"


@pytest.mark.parametrize(
    "line,message",
    [
        ("no semicolon", "no semicolon"),
        ("set;NAME_ONLY", "no semicolon separating the variable"),
        ("frobnicate;X;y", "unknown environment hook type"),
        ("source;share/pkg/noext", "has no extension"),
        ("set;1BAD;x", "invalid environment variable name"),
    ],
)
def test_errors_name_file_and_line(tmp_path: Path, line: str, message: str) -> None:
    prefix = package(tmp_path, f"set;OK;1\n{line}\n")

    with pytest.raises(WsbuildError, match=message) as info:
        resolve_package(prefix, "pkg")
    assert info.value.path == prefix / "share/pkg/package.dsv"
    assert info.value.line == 2


def test_dsv_files_sourcing_each_other_are_reported(tmp_path: Path) -> None:
    prefix = package(tmp_path, "source;share/pkg/package.dsv\n")

    with pytest.raises(WsbuildError, match="source each other"):
        resolve_package(prefix, "pkg")


def test_missing_package_dsv(tmp_path: Path) -> None:
    resolved = resolve_package(tmp_path, "pkg")

    assert resolved.operations == ()
    assert resolved.files == (tmp_path / "share/pkg/package.dsv",)
