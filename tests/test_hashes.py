"""wsbuild/hashes.py: the hashes taken without hashlib give hashlib's digests (records,
keys and file names made before stay valid)."""

from __future__ import annotations

import hashlib

from wsbuild import hashes


def test_each_hash_gives_hashlibs_digest() -> None:
    for data in (b"", b"abc", bytes(range(256)) * 400):
        assert hashes.sha256(data).hexdigest() == hashlib.sha256(data).hexdigest()
        assert hashes.blake2b(data, digest_size=16).hexdigest() == \
            hashlib.blake2b(data, digest_size=16).hexdigest()
        stream = hashes.sha256_stream()
        for start in range(0, len(data), 4096):
            stream.update(data[start:start + 4096])
        assert stream.hexdigest() == hashlib.sha256(data).hexdigest()
