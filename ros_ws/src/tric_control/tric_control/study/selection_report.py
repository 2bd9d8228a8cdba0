"""The selection's own study (tric-study --every-candidate): how each score ranks a cell's
candidates against their results on the task's validation set, and what choosing the best of the
first S of each group by it gives, beside a candidate drawn blindly and the best in hindsight.
ROS-free; plain numbers from study.json's rows.

The validation result of a candidate: its mean grasp cost on the task's validation set (lower is
better), or minus its boxes opened. A group is a cell (variant, task, group seed) with its
candidates measured.

A few groups give a noisy answer: each group's choice is one candidate. The pooled estimate reads
every candidate of a variant and task at once: the expected result of each score's choice among S
candidates drawn from all of them (S the groups' size), with its spread over bootstrap resamples of
the candidates; it compares training variants with far less of the choice's noise."""

import itertools
import math

import numpy as np
from scipy.stats import spearmanr

from tric_control.selection.settings import DEFAULT_SCORE, SCORES
from tric_control.study.variants import TASKS


def validation_result(sets: dict, task: str) -> float:
    """A model's result on the task's validation set (its last set): lower is better."""
    measured = sets[TASKS[task][1][-1]]
    return -float(measured["opened"]) if "opened" in measured else float(measured["cost_mean"])


def selection_report(rows: list) -> dict:
    """{(variant, task): {"groups": count, "spearman": {score: rho}, "best_of": {S: {score: [the
    chosen candidate's validation result per group]}, "blind": {S: [per group]}, "hindsight":
    {S: [per group]}, "picks_best": {S: {score: groups where the score picked the hindsight
    best}}, "pooled": {"size": S, "blind", "hindsight", "by_score": {score: (pooled_choice,
    bootstrap_spread)}}}} over the rows that hold their candidates (every_candidate); S the
    smallest group's size."""
    report = {}
    for (variant, task), cells in _cells_by_variant(rows).items():
        candidates = [[_scored(c, task) for c in row["candidates"]] for row in cells]
        results = [v for group in candidates for _, v in group]
        spearman = {}
        for name in SCORES:
            scored = [(s[name], v) for group in candidates for s, v in group if s[name] is not None]
            finite = [(s, v) for s, v in scored if math.isfinite(s)]
            spearman[name] = (
                float(spearmanr(*zip(*finite)).correlation) if len(finite) > 2 else math.nan
            )
        sizes = range(1, min(len(group) for group in candidates) + 1)
        best_of: dict = {}
        blind: dict = {}
        hindsight: dict = {}
        picks: dict = {}
        for size in sizes:
            firsts = [group[:size] for group in candidates]
            blind[size] = [float(np.mean([v for _, v in group])) for group in firsts]
            hindsight[size] = [min(v for _, v in group) for group in firsts]
            best_of[size], picks[size] = {}, {}
            for name in SCORES:
                chosen = [_best(group, name)[1] for group in firsts]
                best_of[size][name] = chosen
                picks[size][name] = sum(c == h for c, h in zip(chosen, hindsight[size]))
        pooled = [candidate for group in candidates for candidate in group]
        size = max(sizes)
        report[(variant, task)] = {
            "groups": len(cells),
            "candidates": len(results),
            "spearman": spearman,
            "best_of": best_of,
            "blind": blind,
            "hindsight": hindsight,
            "picks_best": picks,
            "pooled": {
                "size": size,
                "blind": float(np.mean(results)),
                "hindsight": pooled_choice(pooled, size, None),
                "by_score": {
                    name: (pooled_choice(pooled, size, name), bootstrap_spread(pooled, size, name))
                    for name in SCORES
                },
            },
        }
    return report


#: Draws of S candidates for the pooled estimate (every subset when there are at most as many).
POOLED_DRAWS = 4000
#: Bootstrap resamples of the candidates for the pooled estimate's spread, and draws in each.
BOOTSTRAP_RESAMPLES, BOOTSTRAP_DRAWS = 200, 200


def pooled_choice(candidates: list, size: int, name, draws: int = POOLED_DRAWS, seed: int = 0):
    """The expected validation result of the candidate the score name ranks first (None: the best
    in hindsight) among size candidates drawn without replacement from candidates ([(scores,
    validation result)]): the mean over every subset when there are at most draws of them, else
    over draws subsets drawn at random (seed)."""
    results = np.array([result for _, result in candidates], dtype=float)
    ranks = results if name is None else np.array([_rank(s[name]) for s, _ in candidates])
    if math.comb(len(candidates), size) <= draws:
        subsets = np.array(list(itertools.combinations(range(len(candidates)), size)))
    else:
        randoms = np.random.default_rng(seed).random((draws, len(candidates)))
        subsets = np.argsort(randoms, axis=1)[:, :size]
    picks = subsets[np.arange(len(subsets)), np.argmin(ranks[subsets], axis=1)]
    return float(results[picks].mean())


def bootstrap_spread(candidates: list, size: int, name, seed: int = 0) -> float:
    """The standard deviation of pooled_choice over BOOTSTRAP_RESAMPLES resamples of candidates
    (drawn with replacement, BOOTSTRAP_DRAWS subsets each): how far another set of candidates of
    the same training would move the estimate."""
    return float(np.std(_bootstrap([candidates], size, name, seed)[:, 0]))


def paired_difference(first: dict, second: dict, size: int, name, seed: int = 0) -> tuple:
    """(pooled_choice of first minus that of second, its bootstrap sd, the candidates paired) over
    the candidate seeds both hold (first, second: {seed: (scores, validation result)}): the same
    subsets of seeds drawn for both, and the same resamples, so that what the two trainings share
    (a seed's draw of noisy samples) cancels."""
    common = sorted(set(first) & set(second))
    pair = [[first[k] for k in common], [second[k] for k in common]]
    difference = pooled_choice(pair[0], size, name, seed=seed) - pooled_choice(
        pair[1], size, name, seed=seed
    )
    estimates = _bootstrap(pair, size, name, seed)
    return difference, float(np.std(estimates[:, 0] - estimates[:, 1])), len(common)


def variant_differences(rows: list, name: str = DEFAULT_SCORE) -> dict:
    """{(task, first variant, second variant): paired_difference} for every two variants of a
    task whose rows hold their candidates (every_candidate) and share at least S candidate
    seeds, by the score name (the selection's default); S the smallest group's size of the two."""
    pools: dict = {}
    sizes: dict = {}
    for (variant, task), cells in _cells_by_variant(rows).items():
        pools.setdefault(task, {})[variant] = {
            c["seed"]: _scored(c, task) for row in cells for c in row["candidates"]
        }
        sizes[(task, variant)] = min(len(row["candidates"]) for row in cells)
    differences = {}
    for task, variants in pools.items():
        for first, second in itertools.combinations(variants, 2):
            size = min(sizes[(task, first)], sizes[(task, second)])
            if len(set(variants[first]) & set(variants[second])) >= size:
                differences[(task, first, second)] = paired_difference(
                    variants[first], variants[second], size, name
                )
    return differences


def _cells_by_variant(rows: list) -> dict:
    """{(variant, task): [its rows that hold their candidates (every_candidate)]}."""
    cells: dict = {}
    for row in rows:
        if "candidates" in row:
            cells.setdefault((row["variant"], row["task"]), []).append(row)
    return cells


def _scored(candidate: dict, task: str) -> tuple:
    """A candidate row's (scores, validation result)."""
    return candidate["scores"], validation_result(candidate["sets"], task)


def _sign(task: str) -> int:
    """-1 for a box (results are minus the boxes opened; lines print the boxes), else 1."""
    return -1 if task == "box" else 1


def _bootstrap(pools: list, size: int, name, seed: int) -> np.ndarray:
    """(BOOTSTRAP_RESAMPLES, len(pools)) pooled_choice of each pool (equally long lists) over the
    same resamples with replacement, BOOTSTRAP_DRAWS subsets each."""
    rng = np.random.default_rng(seed)
    estimates = []
    for resample in range(BOOTSTRAP_RESAMPLES):
        drawn = rng.integers(len(pools[0]), size=len(pools[0]))
        estimates.append(
            [
                pooled_choice(
                    [pool[k] for k in drawn], size, name, BOOTSTRAP_DRAWS, seed + 1 + resample
                )
                for pool in pools
            ]
        )
    return np.array(estimates)


def _best(group: list, name: str) -> tuple:
    """The (scores, validation result) of group whose score name ranks first."""
    return min(group, key=lambda candidate: _rank(candidate[0][name]))


def _rank(score) -> float:
    """A score for ranking: missing or non-finite (failed rollouts) last."""
    return score if score is not None and math.isfinite(score) else math.inf


def report_lines(report: dict) -> list:
    """The report as text lines, one block per variant and task."""
    lines = []
    for (variant, task), numbers in report.items():
        unit = "boxes opened" if task == "box" else "mean cost"
        sign = _sign(task)
        lines.append(
            f"{variant} / {task}: {numbers['candidates']} candidates in {numbers['groups']} "
            f"groups; the validation {unit} of the candidate each score chooses"
        )
        spearman = ", ".join(
            f"{name} {rho:+.2f}" for name, rho in numbers["spearman"].items() if math.isfinite(rho)
        )
        lines.append(f"  Spearman against the validation result: {spearman}")
        for size, by_score in numbers["best_of"].items():
            lines.append(
                f"  best of {size}: blind {_cells(numbers['blind'][size], sign)}, hindsight "
                f"{_cells(numbers['hindsight'][size], sign)}"
            )
            for name, chosen in by_score.items():
                best = numbers["picks_best"][size][name]
                lines.append(
                    f"    {name:10s} {_cells(chosen, sign)}, the best in {best} of "
                    f"{numbers['groups']}"
                )
        pooled = numbers["pooled"]
        lines.append(
            f"  pooled: the expected result of the choice among {pooled['size']} of all "
            f"{numbers['candidates']} candidates (+- its bootstrap sd): blind "
            f"{sign * pooled['blind']:.3g}, "
            f"hindsight {sign * pooled['hindsight']:.3g}"
        )
        for name, (mean, spread) in pooled["by_score"].items():
            lines.append(f"    {name:10s} {sign * mean:.3g} +- {spread:.2g}")
    return lines


def difference_lines(differences: dict) -> list:
    """variant_differences as text lines (boxes: opened, not minus it)."""
    lines = []
    for (task, first, second), (difference, spread, paired) in differences.items():
        sign = _sign(task)
        lines.append(
            f"{task}: {first} minus {second}, pooled, the default score's choice: "
            f"{sign * difference:+.3g} +- {spread:.2g} ({paired} candidates paired by seed)"
        )
    return lines


def _cells(values, sign: int) -> str:
    """'a/b/c (mean m)' of per-group values, each times sign (boxes: opened, not minus it)."""
    values = [sign * v for v in values]
    return f"{'/'.join(format(v, '.3g') for v in values)} (mean {np.mean(values):.3g})"
