"""What tric-train shows (tric_control.train_cli): its progress bars (the stages of a DPL
training, the candidates of a TRIC selection) and the summary lines printed at its end. Light:
tqdm only; the summaries read the finished run's records."""

import sys

from tqdm import tqdm


class StageBars:
    """progress(stage, fraction, losses) for a DPL training (train_dpl_from_bags) as one tqdm bar
    per stage: bags loaded, optimizer iterations (with the current loss)."""

    def __init__(self, bags: int, max_iterations: int, enabled: bool = True):
        self.totals = {"loading": (bags, "bag"), "optimizing": (max_iterations, "it")}
        self.enabled = enabled
        self.stage: str | None = None
        self.bar: tqdm | None = None

    def __call__(self, stage: str, fraction: float, losses):
        if stage != self.stage:
            self.close()
            self.stage = stage
            if stage in self.totals:
                total, unit = self.totals[stage]
                self.bar = tqdm(
                    total=total,
                    desc=f"{stage:10s}",
                    unit=unit,
                    disable=not self.enabled,
                    file=sys.stderr,
                )
        if self.bar is None:
            return
        total = self.totals[stage][0]
        done = round(fraction * total)
        self.bar.update(min(done, total) - self.bar.n)
        if stage == "optimizing":
            self.bar.set_postfix_str(f"L {losses['total']:.4f}", refresh=False)

    def close(self):
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class CandidateBar:
    """progress(stage, fraction, what) for select_from_bags: one tqdm bar over the candidates
    (total of them), each one's times shown as it ends."""

    def __init__(self, total: int, enabled: bool = True):
        self.total, self.enabled = total, enabled
        self.bar: tqdm | None = None

    def __call__(self, stage: str, fraction: float, what):
        if stage != "candidates":
            return
        if self.bar is None:
            self.bar = tqdm(
                total=self.total,
                desc="candidates",
                unit="model",
                disable=not self.enabled,
                file=sys.stderr,
            )
        if what is not None and not isinstance(what, Exception):
            self.bar.set_postfix_str(
                f"seed {what.seed}: trained {what.train_s:.0f} s, "
                f"{len(what.rollouts)} rollouts {what.rollout_s:.0f} s",
                refresh=False,
            )
        self.bar.update(round(fraction * self.total) - self.bar.n)

    def close(self):
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def chosen_text(selection: dict) -> str:
    """'the best' or 'the best N' of a selection's settings."""
    return "the best" if selection["members"] == 1 else f"the best {selection['members']}"


def summary(run) -> str:
    """The lines printed after a TRIC training: the chosen model, then every candidate."""
    model_file = run.choice.model
    info, provenance = model_file.info, run.choice.provenance
    losses = info["losses"]
    config = info["hyperparameters"]
    steps = sum(demo.length for demo in run.dataset.demos)
    selection = provenance["config"]
    robot, _, digest = info.get("robot_profile", "").partition(":")
    lines = [
        f"model      {run.path}",
        *([f"robot      {robot} (profile digest {digest[:12]})"] if digest else []),
        f"data       {len(run.dataset.demos)} demonstrations, {steps} steps, "
        f"{info['mean_samples_per_step']:.1f} noisy samples per step",
        f"chosen     {chosen_text(selection)} "
        f"of {selection['candidates']} candidates by the score '{selection['score']}': seed "
        f"{', '.join(str(seed) for seed in provenance['chosen'])}",
        f"losses     total {losses['total']:.4f} = {config['alpha_n']:g} L_n {losses['n']:.4f} + "
        f"{config['alpha_g']:g} L_g {losses['g']:.4f} + {config['alpha_w']:g} |w|_1 "
        f"{losses['w']:.2f} (L_n, L_g per demonstration step; an ensemble's: its members' mean)",
        f"features   {model_file.definition.size} -> {len(info['kept_features'])} kept -> "
        f"{info['selected_features']} selected",
        f"controller delta {info['delta']:.4g}, rho {info['rho']:.4g}",
        f"time       {run.wall_s:.1f} s in all",
        "candidates (the hidden metrics' successes on the rollouts, a grasp's without the lift "
        "test unless the score is successes: a reference, not the score's input unless the score "
        "is judge or successes)",
    ]
    for row in provenance["candidates"]:
        successes = sum(bool(r["success"]) for r in row["rollouts"])
        score = "failed" if row["score"] is None else f"{row['score']:.4g}"
        lines.append(
            f"  {'*' if row['chosen'] else ' '} seed {row['seed']:<6d} score {score:>9s}  "
            f"trained {row['train_s']:5.1f} s  rollouts {row['rollout_s']:5.1f} s  "
            f"successes {successes}/{len(row['rollouts'])}"
        )
    for failure in provenance.get("failed", []):
        lines.append(f"  failed {failure}")
    return "\n".join(lines)


def dpl_summary(run) -> str:
    """The lines printed after a DPL training."""
    result, scaling = run.result, run.result.policy.scaling
    steps = sum(demo.length - 1 for demo in run.dataset.demos)
    unit = "rad" if result.kind == "dpl_joint" else "m"
    return "\n".join(
        [
            f"model      {run.path} ({result.kind})",
            f"data       {len(run.dataset.demos)} demonstrations, {steps} steps of "
            f"{result.sample_period_s * 1e3:.0f} ms",
            f"losses     training MSE {result.losses['mse']:.4g} {unit}^2 per output, mean "
            f"|error| {result.losses['mean_abs_error']:.4g} {unit} (targets' RMS "
            f"{result.target_rms:.4g} {unit})",
            f"features   {scaling.size} -> {len(scaling.kept)} kept",
            f"time       optimization {result.optimization_time_s:.2f} s ({result.iterations} "
            "iterations)",
        ]
    )
