"""The analysis (Fig. 12-17): the sphere, cylinder and box models on their demonstrations, three
seeds each: f along every demo, the cosines of L_g, the collision prior, kernel PCA, the feature
scores and the mean gradients df/dy by step."""

import math

from tric_control.experiments.paper import PAPER_REPORTS, PAPER_SELECTED_FEATURES
from tric_control.experiments.rows import (
    spread,
)
from tric_control.experiments.runner import SEEDS, Runner
from tric_control.experiments.targets import (
    COSINE_TARGET,
    FALLING_TARGET,
    FEATURES_AIM,
    SLOW_COSINE_TARGET,
    WEIGHTED_COSINE_TARGET,
)
from tric_learning import analysis, model_file
from tric_learning.analysis.attraction import attraction_numbers, rollouts_from_demo_ends
from tric_learning.bags.loader import load_dataset
from tric_learning.model_file import ModelFile
from tric_learning.training.value import SELECTED_FRACTION

#: The experiment's heading in the report and the log.
TITLE = "The models of spheres, cylinders and boxes (three groups each) on their demonstrations:"


#: The analysis' tasks: the bags each model is trained on, and the model's name.
ANALYSIS_TASKS = {"sphere": "sphere_k30", "cylinder": "cylinder_k30", "box": "box_k30"}


#: Features shown in the analysis' Fig. 16 and 17a and listed in its JSON.
TOP_FEATURES = 20


def run(runner: Runner) -> dict:
    """The experiment's rows, table, figure(s), the paper's numbers and the discussion."""
    rows: dict[str, dict]
    rows, figures = {}, []
    for task, name in ANALYSIS_TASKS.items():
        dataset = load_dataset([runner.bags(task)], runner.robot)
        rows[task] = {}
        for seed in SEEDS:
            loaded = ModelFile.load(
                runner.model(name, task, seed=seed), expected=dataset.definition
            )
            model = model_file.value_function(loaded)
            rows[task][seed] = analysis.key_numbers(model, dataset, TOP_FEATURES)
            rows[task][seed]["prop2"] = attraction_numbers(
                rollouts_from_demo_ends(
                    model, dataset, runner.robot, loaded.info["delta"], loaded.info["rho"]
                )
            )
            if seed == SEEDS[0]:
                paths = analysis.write_figures(
                    model, dataset, runner.out / "analysis" / task, TOP_FEATURES, robot=runner.robot
                )
                figures += [str(path.relative_to(runner.out)) for path in paths]
    lines = [
        f"{'task':9s} {'seed':>4s} {'cos |dq|-wtd':>12s} {'cos moving':>10s} {'cos slow':>8s} "
        f"{'f falls':>7s} {'early':>7s} {'late':>7s} {'demos ending lower':>19s} "
        f"{'95% weight':>10s} {'selected':>9s} {'Prop. 2 back':>12s} {'undershoot':>10s}"
    ]
    for task, seeds in rows.items():
        for seed, n in seeds.items():
            lines.append(
                f"{task:9s} {seed:4d} {n['cosine_weighted']:12.3f} {n['cosine_moving']:10.3f} "
                f"{n['cosine_slow']:8.3f} {n['falls']:7.1%} {n['cosine_moving_early']:7.3f} "
                f"{n['cosine_moving_late']:7.3f} "
                f"{n['demos_ending_lower']:>12d}/{n['demos']:<6d} "
                f"{n['features_95']:10d} {n['selected_features']:4d}/{n['kept_features']:<4d} "
                f"{n['prop2']['came_back']:12.0%} {n['prop2']['undershoot_median']:10.3f}"
            )
    sphere = rows["sphere"][SEEDS[0]]
    lines.append(
        "top features of the sphere model (seed 0): "
        + ", ".join(f"{t['name']} {t['score']:.3g}" for t in sphere["top_features"][:8])
    )
    return {
        "rows": rows,
        "table": "\n".join(lines),
        "figures": figures,
        "paper": PAPER_REPORTS["analysis"],
        "discussion": discussion(rows),
    }


def discussion(rows: dict) -> str:
    parts = []
    for task, seeds in rows.items():
        numbers = list(seeds.values())
        weighted = [n["cosine_weighted"] for n in numbers]
        moving = [n["cosine_moving"] for n in numbers]
        falls = [n["falls"] for n in numbers]
        met = sum(
            w <= WEIGHTED_COSINE_TARGET and f >= FALLING_TARGET for w, f in zip(weighted, falls)
        )
        text = (
            f"{task}: mean cosine {spread(weighted, '.3f')} weighted by |dq| "
            f"({spread(moving, '.3f')} over the steps that move at all; the design's <= "
            f"{COSINE_TARGET}), f falling on {spread(falls, '.3f')} of the steps of at least "
            f"0.01 rad; {met} of {len(numbers)} seeds meet <= {WEIGHTED_COSINE_TARGET} and >= "
            f"{FALLING_TARGET:.0%}"
        )
        back = [n["prop2"]["came_back"] for n in numbers]
        under = [n["prop2"]["undershoot_median"] for n in numbers]
        text += (
            f"; Prop. 2, rollouts from states around the demonstrations' ends: "
            f"{spread([100 * b for b in back], '.0f')}% come back to rest nearer y_T, and f goes "
            f"below f(y_T) by {spread(under, '.3f')} of the demonstrations' fall (median)"
        )
        if task == "box":
            slow = [n["cosine_slow"] for n in numbers]
            text += (
                f"; over the slow steps (the lid lifting) {spread(slow, '.3f')}, "
                f"{sum(c <= SLOW_COSINE_TARGET for c in slow)} of {len(slow)} at most "
                f"{SLOW_COSINE_TARGET}"
            )
        parts.append(text + ".")
    text = "Over the groups " + "/".join(map(str, SEEDS)) + ": " + " ".join(parts) + " "
    sphere = rows["sphere"][SEEDS[0]]
    early, late = sphere["cosine_moving_early"], sphere["cosine_moving_late"]
    if math.isfinite(late):
        text += (
            f"On spheres (seed {SEEDS[0]}) the cosine is {late:.2f} from step "
            f"{sphere['late_from_step']} on, against {early:.2f} before: "
            + (
                "worse late, as in the paper. "
                if late > early + 0.05
                else "better late, unlike the paper. "
                if late < early - 0.05
                else "about the same, unlike the paper. "
            )
        )
    selected = [n["selected_features"] for seeds in rows.values() for n in seeds.values()]
    carrying = [n["features_95"] for seeds in rows.values() for n in seeds.values()]
    text += (
        f"The features carrying 95% of the score, all models: {min(carrying)} to "
        f"{max(carrying)} (the aim: {FEATURES_AIM} or fewer; the paper: about "
        f"{PAPER_SELECTED_FEATURES}, without saying where it draws the line); with a score above "
        f"{SELECTED_FRACTION:.0%} of the largest, {min(selected)} to {max(selected)}. "
    )
    pairs = [
        name[name.index("[") + 1 : name.index("]")].replace("->", ",").split(",")
        for name in (t["name"] for t in sphere["top_features"][:10])
    ]
    to_object = sum("object" in pair for pair in pairs)
    text += (
        f"Of the sphere model's top {len(pairs)} features, {to_object} relate a hand landmark to "
        "the object (the paper's top ones are finger-to-target distances); "
        f"{sphere['top_gradients_changing_sign']} of the top {TOP_FEATURES} change the sign of "
        "their mean gradient over time (the paper shows its 8th doing so)."
    )
    return text
