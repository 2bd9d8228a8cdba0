"""tric-experiments: the paper's experiments, each one command, through the real nodes.

    tric-experiments [NAME ...] [--out DIR] [--situations N]

NAME (default: all, in this order):
  table2  DPL's training and test errors |u - pi(y)| per joint (rad), beside |u| (paper Table 2);
          the test set is the 15 sphere test situations demonstrated by the teacher.
  fig9    TRIC and DPL grasp cost on the training situations with the sphere moved by Gaussian
          noise of 0, 2 and 4 cm per axis (paper Fig. 9; --situations each, default 30).
  table3  cylinders: the teacher, TRIC K = 0 and TRIC K = 30 (paper Table 3).
  exp4    the sphere model facing an obstacle in the approach path, never seen in training.
  table4  boxes opened out of 25: TRIC, DPL in joint space, DPL in finger space, the teacher.

Models are trained on the reference bags in bags/ (kept in DIR/models and re-used when present).
Each experiment writes DIR/<name>.json, DIR/<name>.png and prints its table; DIR/REPORT.md is then
rewritten from every experiment's JSON found in DIR, each table beside the paper's numbers.
"""

import argparse
import json
import math
import pathlib
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tric_control.evaluate_cli import evaluate  # noqa: E402
from tric_control.evaluation import report, summarize, write_json  # noqa: E402
from tric_learning import dpl  # noqa: E402
from tric_learning.record_cli import demonstrate_all, private_domain_id  # noqa: E402
from tric_learning.recording import load_dataset  # noqa: E402
from tric_learning.model_file import ModelFile  # noqa: E402
from tric_learning.training import TrainingConfig, train_from_bags  # noqa: E402
from tric_sim import situations  # noqa: E402
from tric_sim.robot_model import RobotModel  # noqa: E402

BAGS = pathlib.Path("bags")
#: Control ticks per box episode: the box demonstrations last 8 s (800 ticks at 100 Hz).
BOX_STEPS = 1200


class Runner:
    """Trains (or re-uses) models under out/models and runs evaluations in one private DDS domain."""

    def __init__(self, out: pathlib.Path):
        self.out = out
        self.robot = RobotModel()
        self.domain_id = private_domain_id()
        (out / "models").mkdir(parents=True, exist_ok=True)

    def model(self, name: str, bags: str, kind: str = "tric", hidden_units: int = 30) -> pathlib.Path:
        """The model file out/models/<name>.safetensors, trained on bags/<bags> if it is missing."""
        path = self.out / "models" / f"{name}.safetensors"
        if not path.is_file():
            print(f"training {name} on {BAGS / bags}", flush=True)
            if kind == "tric":
                train_from_bags([BAGS / bags], path, TrainingConfig(hidden_units=hidden_units), self.robot)
            else:
                dpl.train_dpl_from_bags([BAGS / bags], path, dpl.DplConfig(), self.robot, kind=kind)
        return path

    def evaluate(self, chosen, model, desc: str, max_steps: int = 0):
        return evaluate(chosen, model, max_steps, domain_id=self.domain_id, desc=desc)


def table2(runner: Runner, count: int) -> dict:
    """DPL errors on its training demonstrations and on teacher demonstrations of the test set."""
    test_bags = runner.out / "bags" / "sphere_test"
    if not sorted(test_bags.glob("*.mcap")):
        demonstrate_all(situations.dataset("sphere_test"), test_bags, 0.125, 0.0, domain_id=runner.domain_id)
    policy = dpl.load_policy(ModelFile.load(runner.model("sphere_dpl_joint", "sphere", "dpl_joint")))
    rows = {}
    for name, paths in (("training", [BAGS / "sphere"]), ("test", [test_bags])):
        dataset = load_dataset(paths, runner.robot)
        inputs, targets = dpl.training_pairs(dataset, "dpl_joint")
        rows[name] = {"speed": float(np.mean(np.abs(targets))),
                      "error": float(np.mean(np.abs(policy.predict(inputs) - targets))), "steps": len(targets)}
    text = (f"{'set':10s} {'|u| (rad)':>10s} {'|u - pi| (rad)':>15s} {'steps':>6s}\n"
            + "\n".join(f"{k:10s} {v['speed']:10.4f} {v['error']:15.4f} {v['steps']:6d}" for k, v in rows.items()))
    figure, axis = plt.subplots(figsize=(5, 3.2))
    axis.bar(["|u|", "train error", "test error"],
             [rows["training"]["speed"], rows["training"]["error"], rows["test"]["error"]])
    axis.set_ylabel("rad per 125 ms step, mean over joints")
    axis.set_title("Table 2: DPL errors")
    return {"rows": rows, "table": text, "figure": figure,
            "paper": "train error much smaller than test error (more data needed to generalize)"}


def fig9(runner: Runner, count: int) -> dict:
    """TRIC and DPL on the training situations, the sphere moved by 0 / 2 / 4 cm noise."""
    base = situations.sphere_grid()
    chosen = [base[k % len(base)] for k in range(count)]
    models = {"TRIC": runner.model("sphere_k30", "sphere"),
              "DPL": runner.model("sphere_dpl_joint", "sphere", "dpl_joint")}
    rows = {}
    for shift in (0.0, 0.02, 0.04):
        tests = situations.shifted(chosen, shift, seed=9)
        for agent, model in models.items():
            records = runner.evaluate(tests, model, f"{agent} at {shift * 100:.0f} cm")
            s = summarize(records)
            rows[f"{agent} {shift * 100:.0f} cm"] = {"agent": agent, "shift_cm": shift * 100,
                                                     "cost_mean": s["grasp_cost_mean"],
                                                     "cost_std": float(np.std([r.grasp_cost for r in records])),
                                                     "good": s["good_grasps"], "episodes": len(records)}
    text = (f"{'agent':6s} {'shift':>6s} {'cost mean':>10s} {'std':>6s} {'good':>6s}\n" + "\n".join(
        f"{r['agent']:6s} {r['shift_cm']:4.0f}cm {r['cost_mean']:10.3f} {r['cost_std']:6.3f} "
        f"{r['good']:3d}/{r['episodes']}" for r in rows.values()))
    figure, axis = plt.subplots(figsize=(5.5, 3.4))
    for agent in models:
        mine = [r for r in rows.values() if r["agent"] == agent]
        axis.errorbar([r["shift_cm"] for r in mine], [r["cost_mean"] for r in mine],
                      yerr=[r["cost_std"] for r in mine], marker="o", capsize=3, label=agent)
    axis.set_xlabel("object shift (cm, std per axis)")
    axis.set_ylabel("grasp cost")
    axis.set_title("Fig. 9: TRIC vs DPL under object shifts")
    axis.legend()
    return {"rows": rows, "table": text, "figure": figure,
            "paper": "DPL degrades with the shift; TRIC stays near the teacher"}


def _cost_bars(title: str, rows: dict):
    figure, axis = plt.subplots(figsize=(5.5, 3.2))
    names = list(rows)
    axis.bar(names, [rows[n]["cost_mean"] for n in names], yerr=[rows[n]["cost_std"] for n in names], capsize=3)
    axis.axhline(0.25, color="grey", linestyle="--", linewidth=1)
    axis.set_ylabel("grasp cost")
    axis.set_title(title)
    return figure


def _grasp_row(records) -> dict:
    s = summarize(records)
    costs = [r.grasp_cost for r in records if math.isfinite(r.grasp_cost)]
    return {"cost_mean": s["grasp_cost_mean"], "cost_std": float(np.std(costs)) if costs else math.nan,
            "good": s["good_grasps"], "lift": s["lift_passed"], "collisions": s["collisions"],
            "episodes": len(records), "records": report(records)["episodes"]}


def _grasp_table(rows: dict) -> str:
    return (f"{'agent':16s} {'cost mean':>10s} {'std':>6s} {'good':>6s} {'lift':>5s} {'collisions':>10s}\n"
            + "\n".join(f"{name:16s} {r['cost_mean']:10.3f} {r['cost_std']:6.3f} {r['good']:3d}/{r['episodes']:<2d} "
                        f"{r['lift']:5d} {r['collisions']:10d}" for name, r in rows.items()))


def table3(runner: Runner, count: int) -> dict:
    """Cylinders: the teacher, TRIC K = 0 and K = 30 on the 10 cylinder test situations."""
    tests = situations.dataset("cylinder_test")
    rows = {"teacher": _grasp_row(runner.evaluate(tests, None, "teacher")),
            "TRIC K = 0": _grasp_row(runner.evaluate(tests, runner.model("cylinder_k0", "cylinder", hidden_units=0),
                                                     "TRIC K = 0")),
            "TRIC K = 30": _grasp_row(runner.evaluate(tests, runner.model("cylinder_k30", "cylinder"),
                                                      "TRIC K = 30"))}
    return {"rows": rows, "table": _grasp_table(rows), "figure": _cost_bars("Table 3: cylinders", rows),
            "paper": "teacher 0.07, TRIC K = 0 0.19, TRIC K = 30 0.09"}


def exp4(runner: Runner, count: int) -> dict:
    """The sphere model with an obstacle in the approach path (never seen in training)."""
    tests = situations.dataset("obstacle_test")
    rows = {"teacher": _grasp_row(runner.evaluate(tests, None, "teacher")),
            "TRIC": _grasp_row(runner.evaluate(tests, runner.model("sphere_k30", "sphere"), "TRIC"))}
    return {"rows": rows, "table": _grasp_table(rows), "figure": _cost_bars("Exp. 4: unseen obstacle", rows),
            "paper": "TRIC finds another grasp around the obstacle, without collision"}


def table4(runner: Runner, count: int) -> dict:
    """Boxes opened out of the 25 test boxes."""
    tests = situations.dataset("box_test")
    agents = {"TRIC": runner.model("box_k30", "box"),
              "DPL joint space": runner.model("box_dpl_joint", "box", "dpl_joint"),
              "DPL finger space": runner.model("box_dpl_finger", "box", "dpl_finger"),
              "teacher": None}
    rows = {}
    for name, model in agents.items():
        records = runner.evaluate(tests, model, name, BOX_STEPS)
        s = summarize(records)
        rows[name] = {"opened": s["boxes_opened"], "episodes": len(records), "lid_mean": s["lid_angle_mean"],
                      "collisions": s["collisions"], "records": report(records)["episodes"]}
    text = (f"{'agent':18s} {'opened':>8s} {'lid mean (rad)':>15s} {'collisions':>10s}\n"
            + "\n".join(f"{n:18s} {r['opened']:4d}/{r['episodes']:<3d} {r['lid_mean']:15.2f} {r['collisions']:10d}"
                        for n, r in rows.items()))
    figure, axis = plt.subplots(figsize=(5.5, 3.2))
    axis.bar(list(rows), [r["opened"] for r in rows.values()])
    axis.set_ylabel(f"boxes opened of {len(tests)}")
    axis.set_title("Table 4: box opening")
    return {"rows": rows, "table": text, "figure": figure, "paper": "TRIC 24, DPL joint 2, DPL finger 9, teacher 25"}


EXPERIMENTS = {"table2": table2, "fig9": fig9, "table3": table3, "exp4": exp4, "table4": table4}


def write_report(out: pathlib.Path) -> pathlib.Path:
    """out/REPORT.md from every experiment JSON in out, in the order of EXPERIMENTS."""
    lines = ["# TRIC experiments", "",
             "Written by `tric-experiments` from the JSON files beside this report; each table is ours,",
             "the paper's numbers follow it.", ""]
    for name, function in EXPERIMENTS.items():
        path = out / f"{name}.json"
        if not path.is_file():
            continue
        data = json.loads(path.read_text())
        lines += [f"## {name}: {function.__doc__.splitlines()[0]}", "", "```", data["table"], "```", "",
                  f"Paper: {data['paper']}.", "", f"![{name}]({name}.png)", "",
                  f"Run {data['date']} in {data['wall_s']:.0f} s.", ""]
    path = out / "REPORT.md"
    path.write_text("\n".join(lines))
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="tric-experiments", description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help=f"experiments to run (default: all of {', '.join(EXPERIMENTS)})")
    parser.add_argument("--out", default="results", help="results folder (default: results)")
    parser.add_argument("--situations", type=int, default=30, help="situations per shift in fig9 (default 30)")
    args = parser.parse_args(argv)
    if not 1 <= args.situations <= 300:
        parser.error("--situations must be in [1, 300]")
    unknown = [name for name in args.names if name not in EXPERIMENTS]
    if unknown:
        parser.error(f"unknown experiment(s) {', '.join(unknown)} (known: {', '.join(EXPERIMENTS)})")
    out = pathlib.Path(args.out)
    runner = Runner(out)
    for name in args.names or list(EXPERIMENTS):
        print(f"\n=== {name}: {EXPERIMENTS[name].__doc__.splitlines()[0]}", flush=True)
        started = time.monotonic()
        try:
            result = EXPERIMENTS[name](runner, args.situations)
        except (ValueError, RuntimeError) as error:
            print(f"tric-experiments: {name}: {error}", file=sys.stderr)
            return 2
        result["figure"].tight_layout()
        result["figure"].savefig(out / f"{name}.png", dpi=110)
        plt.close(result.pop("figure"))
        result.update(date=time.strftime("%Y-%m-%d %H:%M"), wall_s=time.monotonic() - started)
        write_json(out / f"{name}.json", result)
        print(result["table"])
        print(f"paper: {result['paper']}")
    print(f"\nwrote {write_report(out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
