"""The mutation pass (benchmarks/mutants.py) mutates what it says it does: each mutant's text is
in its file exactly once, so a change of the code cannot silently leave a mutant unapplied
(it would be counted as a check the suite does not make, never as one it makes)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from benchmarks.mutants import MUTANTS, Mutant  # noqa: E402


@pytest.mark.parametrize("mutant", MUTANTS, ids=[m.name for m in MUTANTS])
def test_each_mutant_applies_once(mutant: Mutant) -> None:
    text = (REPO / mutant.path).read_text()
    assert text.count(mutant.old) == 1, f"{mutant.name}: its text is not in {mutant.path} once"
    assert mutant.new != mutant.old
    for test in mutant.tests:
        assert (REPO / test.split("::")[0]).is_file(), test
