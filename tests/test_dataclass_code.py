"""wsbuild/dataclass_code.py: the dataclasses' methods compiled in one run are taken from the
kept file in the next, with the same behaviour; a damaged file costs a compile, nothing else."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from wsbuild import dataclass_code

#: a dataclass of each kind wsbuild defines, used as a user of the class would
PROGRAM = """
import json
from dataclasses import FrozenInstanceError, dataclass, field
import wsbuild.dataclass_code as kept
kept.keep({at!r})  # as launch.py does before anything else is imported (its own file here)

@dataclass(frozen=True, slots=True)
class Seen{n}:
    path_{n}: str
    signature: tuple = ()
    names: tuple = field(default_factory=tuple)

@dataclass(slots=True)
class Counter{n}:
    count_{n}: int = 0

a, b = Seen{n}("x", (1, 2)), Seen{n}("x", (1, 2))
try:
    a.path_{n} = "y"
    frozen = False
except FrozenInstanceError:
    frozen = True
counter = Counter{n}()
counter.count_{n} += 2
print(json.dumps({{"compiled": kept.compiled, "equal": a == b, "hash": hash(a) == hash(b),
                  "repr": repr(a), "frozen": frozen, "count": counter.count_{n},
                  "other": Seen{n}("z") != a}}))
"""


def _run(n: int, at: Path) -> dict[str, object]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    done = subprocess.run([sys.executable, "-c", PROGRAM.format(n=n, at=str(at))], env=env,
                          capture_output=True, text=True, timeout=60, check=True)
    return json.loads(done.stdout)


def test_the_next_run_takes_the_kept_code_and_behaves_the_same(tmp_path: Path) -> None:
    # a class no run defined before (its methods' source is new: its fields' names are):
    # compiled, then kept
    n, at = int.from_bytes(os.urandom(4), "big"), tmp_path / "dataclasses.marshal"
    first = _run(n, at)
    assert first["compiled"] >= 4  # __init__, __repr__, __eq__, __hash__ and __setattr__ ...
    second = _run(n, at)
    assert second["compiled"] < first["compiled"]
    assert {k: v for k, v in second.items() if k != "compiled"} == \
        {k: v for k, v in first.items() if k != "compiled"} == {
            "equal": True, "hash": True,
            "repr": f"Seen{n}(path_{n}='x', signature=(1, 2), names=())",
            "frozen": True, "count": 2, "other": True}
    assert at.stat().st_mode & 0o777 == 0o600
    # where the command keeps it: beside wsbuild's bytecode, one file per interpreter
    default = dataclass_code.path()
    assert default is not None and Path(default).parent.name == "__pycache__"
    assert sys.implementation.cache_tag in Path(default).name


def test_a_damaged_file_costs_a_compile_and_nothing_else(tmp_path: Path) -> None:
    n, at = int.from_bytes(os.urandom(4), "big"), tmp_path / "dataclasses.marshal"
    _run(n, at)
    at.write_bytes(b"\x00not marshal data")
    again = _run(n, at)
    assert again["compiled"] >= 4 and again["equal"] and again["frozen"]
