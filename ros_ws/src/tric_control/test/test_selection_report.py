"""The selection's study report (tric_control.study.selection_report): the pooled estimate of a
score's choice, on hand-made candidates whose expected choice is worked out by hand."""

import math

import pytest

from tric_control.selection.settings import SCORES
from tric_control.study.selection_report import (
    bootstrap_spread,
    difference_lines,
    paired_difference,
    pooled_choice,
    report_lines,
    selection_report,
    variant_differences,
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


def row(seed, results, variant="v"):
    """A study row of the task 'cylinder' whose candidates (seeds seed, seed + 1, ...) have every
    score equal to their validation cost."""
    return {
        "variant": variant,
        "task": "cylinder",
        "seed": seed,
        "candidates": [
            {
                "seed": seed + k,
                "scores": {name: r for name in SCORES},
                "sets": {"cylinder_val": {"cost_mean": r}},
            }
            for k, r in enumerate(results)
        ],
    }


def test_the_report_pools_every_group_of_a_variant_and_task():
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


def test_a_paired_difference_draws_the_same_seeds_for_both_variants():
    # one subset of the two shared seeds: the first variant keeps seed 0 (0.1), the second seed 1
    # (0.5); seed 2 is the second's alone and left out
    first = {0: ({"landmarks": 1}, 0.1), 1: ({"landmarks": 2}, 0.3)}
    second = {0: ({"landmarks": 2}, 0.2), 1: ({"landmarks": 1}, 0.5), 2: ({"landmarks": 0}, 0.0)}
    difference, spread, paired = paired_difference(first, second, 2, "landmarks")
    assert difference == pytest.approx(-0.4) and paired == 2
    # resamples [0, 0] and [1, 1] give -0.1 and -0.2, so the difference spreads
    assert spread > 0
    assert paired_difference(first, first, 2, "landmarks") == (0.0, 0.0, 2)


def test_variants_are_compared_where_they_share_candidate_seeds():
    rows = [
        row(0, [0.1, 0.4], "a"),
        row(100, [0.2, 0.3], "a"),
        row(0, [0.2, 0.5], "b"),  # a's costs plus 0.1, ranked alike
        row(100, [0.3, 0.4], "b"),
        row(500, [0.1, 0.1], "c"),  # no seed in common with a or b
        row(101, [0.1, 0.1], "d"),  # one seed in common with a and b, fewer than a group's 2
    ]
    differences = variant_differences(rows)
    assert sorted(differences) == [("cylinder", "a", "b")]
    difference, _, paired = differences[("cylinder", "a", "b")]
    # in every draw b keeps the same seed as a, at 0.1 more; so in every resample too
    assert paired == 4 and difference == pytest.approx(-0.1)
    assert differences[("cylinder", "a", "b")][1] == pytest.approx(0.0, abs=1e-12)
    assert difference_lines(differences)[0].startswith(
        "cylinder: a minus b, pooled, the default score's choice: -0.1 +- "
    )
