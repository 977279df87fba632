"""benchmarks/cache.py's verdict on what the cache costs a cold build (pure logic)."""

from __future__ import annotations

import sys

from conftest import REPO

sys.path.insert(0, str(REPO))

from benchmarks.cache import CacheCost, Result, cost_lines  # noqa: E402
from benchmarks.measure import Measurement, Sample  # noqa: E402


def measurement(*seconds: float) -> Measurement:
    return Measurement(samples=[Sample(s, s * 1.6, "") for s in seconds])


def test_cost_inside_wsbuild_is_build_threads_plus_packing_cpu() -> None:
    result = Result("mixed", 36, cache_costs=[CacheCost(0.10, 0.20), CacheCost(0.08, 0.18)])
    inside, _, wall = cost_lines(result, measurement(5.0, 6.0), measurement(5.2, 6.1))
    assert "0.09 s in the build's threads" in inside and "0.19 s CPU" in inside
    assert "0.28 s of 5.65 s = **5.0 %** (target ≤ 5 %: ✔" in inside
    assert "median +2.8 %" in wall and "(+4, +2 %)" in wall and "within the noise" in wall


def test_a_cost_over_the_target_and_over_the_noise_says_so() -> None:
    result = Result("mixed", 36, cache_costs=[CacheCost(0.5, 0.5)])
    inside, _, wall = cost_lines(result, measurement(5.0, 5.1), measurement(6.0, 6.2))
    assert "target ≤ 5 %: ✘" in inside
    assert "larger than the noise" in wall


def test_no_rounds_is_not_a_measurement() -> None:
    assert cost_lines(Result("mixed", 36), Measurement(), Measurement()) == [
        "Cost of the cache on a cold build: not measured."]
