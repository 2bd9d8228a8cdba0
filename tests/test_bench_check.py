"""benchmarks/run.py --check: each key with a target compared with it, on hand-made results."""

import importlib.util
import json
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[1]


def bench_runner():
    spec = importlib.util.spec_from_file_location("bench_run", ROOT / "benchmarks" / "run.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_ratios_are_derived_from_keys_of_one_run_and_only_when_all_are_there():
    runner = bench_runner()
    measured = {
        "sim_lockstep_period_us": 300,
        "sim_physics_period_us": 200,
        "sim_ros_round_trip_us": 120,
    }
    ratios = runner.derived(measured)
    assert ratios == {"sim_lockstep_overhead": 1.5, "ros_round_trip_over_physics": 0.6}
    assert "ros_round_trip_over_physics" not in runner.derived(
        {k: v for k, v in measured.items() if k != "sim_physics_period_us"}
    )


def test_the_offline_benchmark_times_a_call_once_where_timed_calls_nest():
    """bench_offline's floor: the judge's lift test steps the physics, and those steps count as
    the judge's, not as the loop's physics."""
    spec = importlib.util.spec_from_file_location(
        "bench_offline", ROOT / "benchmarks" / "bench_offline.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    calls = []

    class World:
        def step(self):
            calls.append("step")

        def judge(self):
            for _ in range(3):
                self.step()

    seconds: dict = {}
    with (
        module.timed(World, "step", seconds, "physics"),
        module.timed(World, "judge", seconds, "judge"),
    ):
        world = World()
        world.step()
        world.judge()
        stepped_alone = seconds["physics"]
        assert 0.0 < stepped_alone and seconds["judge"] > 0.0
        world.judge()
        assert seconds["physics"] == stepped_alone  # the judge's steps are the judge's
    assert calls == ["step"] * 7
    assert World.step.__name__ == "step" and not hasattr(World.step, "__wrapped__")


def test_check_only_exits_by_the_targets_and_derives_the_lockstep_ratio(tmp_path, capsys):
    runner = bench_runner()
    results = {"train_default_s": 15.0, "help_max_s": 0.2, "machine_cpus": 2}
    results.update(runner.derived({"sim_lockstep_period_us": 300, "sim_physics_period_us": 200}))
    assert results["sim_lockstep_overhead"] == 1.5
    path = tmp_path / "bench.json"
    path.write_text(json.dumps(results))
    assert runner.main(["--check-only", "--out", str(path)]) == 0
    printed = capsys.readouterr().out
    assert "met    train_default_s" in printed and "machine_cpus" not in printed
    path.write_text(json.dumps({**results, "help_max_s": 0.5}))  # the target is under 0.5 s
    assert runner.main(["--check-only", "--out", str(path)]) == 1
    assert "MISSED help_max_s" in capsys.readouterr().out
