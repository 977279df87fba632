"""Cache entries: packing is faithful and deterministic; unpacking refuses every poisoned archive
and never writes outside its destination."""

from __future__ import annotations

import io
import os
import stat
import tarfile
from collections.abc import Callable
from pathlib import Path

import pytest
import zstandard

from wsbuild.cache.archive import RefusedEntry, pack, unpack


def tree_of(root: Path) -> dict[str, tuple[str, object, int]]:
    """Every path below root: (kind, content or link target, permission bits)."""
    result: dict[str, tuple[str, object, int]] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            path = Path(dirpath, name)
            rel = str(path.relative_to(root))
            mode = stat.S_IMODE(path.lstat().st_mode)
            if path.is_symlink():
                result[rel] = ("link", os.readlink(path), 0)
            elif path.is_dir():
                result[rel] = ("dir", None, mode)
            else:
                result[rel] = ("file", path.read_bytes(), mode)
    return result


def make_install(root: Path) -> Path:
    (root / "lib").mkdir(parents=True)
    (root / "lib" / "libfoo.so.1").write_bytes(b"\x7fELF" + bytes(range(256)) * 40)
    (root / "lib" / "libfoo.so").symlink_to("libfoo.so.1")
    (root / "bin").mkdir()
    (root / "bin" / "tool").write_text("#!/bin/sh\necho hi\n")
    (root / "bin" / "tool").chmod(0o755)
    (root / "share" / "foo" / "empty").mkdir(parents=True)
    (root / "share" / "foo" / "package.xml").write_text("<package/>")
    (root / "share" / "foo" / "up").symlink_to("../../lib")
    os.link(root / "share" / "foo" / "package.xml", root / "share" / "foo" / "hard.xml")
    return root


def packed(root: Path, files: list[str] | None = None) -> bytes:
    out = io.BytesIO()
    pack(root, out, files)
    return out.getvalue()


def test_round_trip_keeps_files_links_modes_and_empty_dirs(tmp_path: Path) -> None:
    source = make_install(tmp_path / "src")
    data = packed(source)
    dest = tmp_path / "dest"
    dest.mkdir()
    assert unpack(io.BytesIO(data), dest) > 0
    assert tree_of(dest) == tree_of(source)
    # whole seconds: no PAX header per member
    assert (dest / "lib" / "libfoo.so.1").stat().st_mtime == int((source / "lib" / "libfoo.so.1").stat().st_mtime)


def test_packing_is_deterministic_and_digest_matches(tmp_path: Path) -> None:
    import hashlib

    source = make_install(tmp_path / "src")
    out = io.BytesIO()
    digest, size = pack(source, out)
    assert digest == hashlib.sha256(out.getvalue()).hexdigest() and size == len(out.getvalue())
    assert packed(source) == out.getvalue()


def test_pack_only_listed_files(tmp_path: Path) -> None:
    source = make_install(tmp_path / "src")
    dest = tmp_path / "dest"
    dest.mkdir()
    unpack(io.BytesIO(packed(source, ["bin/tool", "lib/libfoo.so"])), dest)
    assert sorted(tree_of(dest)) == ["bin", "bin/tool", "lib", "lib/libfoo.so"]


@pytest.mark.parametrize("make_bad", [
    lambda root: os.mkfifo(root / "fifo"),
    lambda root: (root / "suid").touch(mode=0o755) or (root / "suid").chmod(0o4755),
    lambda root: (root / "out").symlink_to("/etc/passwd"),
    lambda root: (root / "out").symlink_to("../../elsewhere"),
], ids=["fifo", "setuid", "absolute-link", "escaping-link"])
def test_pack_refuses_trees_an_entry_must_not_hold(tmp_path: Path, make_bad: Callable[[Path], None]) -> None:
    root = tmp_path / "prefix"
    root.mkdir()
    (root / "ok").write_text("fine")
    make_bad(root)
    with pytest.raises(RefusedEntry):
        pack(root, io.BytesIO())


# -- poisoned archives ---------------------------------------------------------------------

def archive(*members: tuple[tarfile.TarInfo, bytes | None]) -> bytes:
    raw = io.BytesIO()
    with tarfile.open(fileobj=raw, mode="w", format=tarfile.PAX_FORMAT) as tar:
        for info, data in members:
            if data is not None:
                info.size = len(data)
            tar.addfile(info, io.BytesIO(data) if data is not None else None)
    return zstandard.ZstdCompressor().compress(raw.getvalue())


def reg(name: str, data: bytes = b"x", mode: int = 0o644) -> tuple[tarfile.TarInfo, bytes]:
    info = tarfile.TarInfo(name)
    info.mode = mode
    return info, data


def special(name: str, kind: bytes, linkname: str = "") -> tuple[tarfile.TarInfo, None]:
    info = tarfile.TarInfo(name)
    info.type = kind
    info.linkname = linkname
    info.mode = 0o777 if kind == tarfile.SYMTYPE else 0o644
    return info, None


POISONED = {
    "absolute-path": [reg("/tmp/evil")],
    "dotdot": [reg("../evil")],
    "dotdot-inside": [reg("share/../../evil")],
    "absolute-link": [special("lib/link", tarfile.SYMTYPE, "/etc")],
    "escaping-link": [special("link", tarfile.SYMTYPE, "../outside")],
    "link-chain": [special("d", tarfile.SYMTYPE, "."), special("d/e", tarfile.SYMTYPE, ".."),
                   reg("d/e/evil")],
    "write-through-link": [special("a", tarfile.SYMTYPE, "x/../.."), reg("a/evil")],
    "hardlink-outside": [special("h", tarfile.LNKTYPE, "../outside/victim")],
    "char-device": [special("dev", tarfile.CHRTYPE)],
    "block-device": [special("dev", tarfile.BLKTYPE)],
    "fifo": [special("fifo", tarfile.FIFOTYPE)],
    "setuid": [reg("bin/su", mode=0o4755)],
    "setgid": [reg("bin/sg", mode=0o2755)],
}


@pytest.mark.parametrize("name", sorted(POISONED))
def test_poisoned_archive_is_refused_and_nothing_leaves_the_destination(tmp_path: Path, name: str) -> None:
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "victim").write_text("precious")
    dest = tmp_path / "stage" / "pkg"
    dest.mkdir(parents=True)
    before = tree_of(tmp_path)
    with pytest.raises(RefusedEntry):
        unpack(io.BytesIO(archive(*POISONED[name])), dest)
    after = {k: v for k, v in tree_of(tmp_path).items() if not k.startswith("stage/pkg/")}
    assert after == before
    assert (outside / "victim").read_text() == "precious"


def test_truncated_and_garbage_archives_are_refused(tmp_path: Path) -> None:
    data = packed(make_install(tmp_path / "src"))
    for bad in (data[: len(data) // 2], b"not an archive at all", b""):
        dest = tmp_path / f"dest{len(bad)}"
        dest.mkdir()
        with pytest.raises(RefusedEntry):
            unpack(io.BytesIO(bad), dest)
