"""The selection's study report (tric_control.study.selection_report): the pooled estimate of a
score's choice, on hand-made candidates whose expected choice is worked out by hand."""

import math

import pytest

from tric_control.selection.settings import SCORES
from tric_control.study.selection_report import (
    bootstrap_spread,
    pooled_choice,
    report_lines,
    selection_report,
)


def candidates(scores, results):
    """[(scores, validation result)] with the score 'landmarks' as given."""
    return [({"landmarks": s}, r) for s, r in zip(scores, results)]


def test_a_score_that_ranks_as_the_results_do_expects_the_mean_best_of_every_subset():
    # costs 0.1 .. 0.4, two drawn of four: the best is 0.1 in 3 of the 6 pairs, 0.2 in 2, 0.3 in 1
    pool = candidates([1, 2, 3, 4], [0.1, 0.2, 0.3, 0.4])
    assert pooled_choice(pool, 2, "landmarks") == pytest.approx((3 * 0.1 + 2 * 0.2 + 0.3) / 6)
    assert pooled_choice(pool, 2, None) == pytest.approx((3 * 0.1 + 2 * 0.2 + 0.3) / 6)


def test_a_score_that_ranks_backwards_expects_the_mean_worst_and_a_failed_rollout_ranks_last():
    pool = candidates([4, 3, 2, 1], [0.1, 0.2, 0.3, 0.4])
    assert pooled_choice(pool, 2, "landmarks") == pytest.approx((3 * 0.4 + 2 * 0.3 + 0.2) / 6)
    failed = candidates([math.inf, None, 1.0], [0.0, 0.0, 0.5])
    assert pooled_choice(failed, 3, "landmarks") == pytest.approx(0.5)


def test_random_draws_approach_the_exact_mean_and_are_reproducible():
    results = [0.05 * k for k in range(20)]
    pool = candidates(results, results)
    exact = pooled_choice(pool, 8, "landmarks", draws=10**6)  # all 125970 subsets
    drawn = pooled_choice(pool, 8, "landmarks", draws=4000)
    assert drawn == pooled_choice(pool, 8, "landmarks", draws=4000)
    assert abs(drawn - exact) < 0.01
    assert exact == pytest.approx(sum(0.05 * k * math.comb(19 - k, 7) for k in range(13)) / 125970)


def test_the_spread_is_zero_where_every_candidate_is_alike_and_positive_where_they_differ():
    assert bootstrap_spread(candidates([1, 2, 3], [0.2, 0.2, 0.2]), 2, "landmarks") == 0.0
    assert bootstrap_spread(candidates([1, 2, 3, 4], [0.1, 0.9, 0.2, 0.5]), 2, "landmarks") > 0


def test_the_report_pools_every_group_of_a_variant_and_task():
    def row(seed, results):
        return {
            "variant": "v",
            "task": "cylinder",
            "seed": seed,
            "candidates": [
                {"scores": {name: r for name in SCORES}, "sets": {"cylinder_val": {"cost_mean": r}}}
                for r in results
            ],
        }

    report = selection_report([row(0, [0.1, 0.4]), row(100, [0.2, 0.3])])
    pooled = report[("v", "cylinder")]["pooled"]
    assert pooled["size"] == 2 and pooled["blind"] == pytest.approx(0.25)
    # every score ranks as the results do: the best of each of the 6 pairs of the 4 candidates
    assert pooled["by_score"]["landmarks"][0] == pytest.approx((3 * 0.1 + 2 * 0.2 + 0.3) / 6)
    assert pooled["hindsight"] == pooled["by_score"]["judge"][0]
    lines = report_lines(report)
    assert any(
        line.startswith("  pooled: the expected result of the choice among 2 of all 4")
        for line in lines
    )
