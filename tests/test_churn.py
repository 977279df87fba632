"""The churn test (benchmarks/churn.py): random sequences of changes to every kind of input a
package's output depends on — files inside packages (also in directories named build, install
or log and in a subdirectory marked COLCON_IGNORE; added, deleted, renamed), outside them
(headers, CMake includes, globbed and installed directories, a dependency's share directory, a
data_files file), a symlink, an environment variable the builds and a test read, a mixin and a
defaults file, a chained underlay workspace, `rm -rf build install` — each followed by an
incremental build and test in wsbuild's default configuration (build cache on, no-op replay
on, build steps under the build-step oracle) whose install/ and test verdicts must equal those
of a build and test from scratch in a fresh copy. 30 sequences in three parts (each part a
workspace of its own, so the suite's two workers share them); `benchmarks/churn.py` runs 200."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from benchmarks.churn import Churn, coverage, operations, run_sequence

#: sequences per part; six parts make the 30 the issue asks CI to run
SEQUENCES = 5
PARTS = 6
#: seconds a part may take: its setup and, for each of its at most SEQUENCES * 2 + its
#: coverage's steps, an incremental build, a no-op, a test and a build and test from scratch
#: (each about 20 s on an idle 2-core machine), four times over for a machine loaded 8-10
PART_SECONDS = 4 * 20 * (SEQUENCES * 2 + 6) + 300


@pytest.fixture(scope="module")
def churns(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[int, Churn]]:
    """One churn workspace per part, made when the part first runs."""
    made: dict[int, Churn] = {}
    yield made


def _churn(churns: dict[int, Churn], part: int, tmp_path_factory: pytest.TempPathFactory
           ) -> Churn:
    if part not in churns:
        root = tmp_path_factory.mktemp(f"churn{part}")
        churn = Churn(root)
        churn.setup()
        churns[part] = churn
    return churns[part]


@pytest.mark.timeout(PART_SECONDS)
@pytest.mark.parametrize("part", range(PARTS))
def test_every_shortcut_answers_as_a_build_from_scratch(
        part: int, churns: dict[int, Churn], tmp_path_factory: pytest.TempPathFactory,
        traced_steps: Path) -> None:
    assert os.environ.get("WSBUILD_STEP_TRACE") == str(traced_steps)
    churn = _churn(churns, part, tmp_path_factory)
    problems = run_sequence(churn, coverage(part, PARTS))
    assert not problems, "\n".join(problems)

    # each part draws its own sequences, the same ones in every run (a failure is reproduced by
    # running the part again; hypothesis then shrinks it to the fewest changes that show it)
    @seed(36 + part)
    @settings(max_examples=SEQUENCES, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(st.lists(st.sampled_from(operations()), min_size=1, max_size=2))
    def sequences(sequence: list[tuple[str, int]]) -> None:
        problems = run_sequence(churn, sequence)
        assert not problems, "\n".join(problems)

    sequences()
