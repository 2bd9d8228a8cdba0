"""tric-study's variants and summaries (the training and offline runs are tested elsewhere)."""

import pytest

from tric_control.study import cli as study
from tric_control.study import measures as study_measures
from tric_control.study import variants as study_variants
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.scene import TASK_CONTACTS


def test_a_variant_is_a_name_and_training_options():
    assert study_variants.parse_variant("default=") == ("default", {})
    name, changes = study_variants.parse_variant(
        "balanced=per_step_weights=true,optimizer=lbfgsb,alpha_g=3,max_iterations=200"
    )
    assert name == "balanced"
    assert changes == {
        "per_step_weights": True,
        "optimizer": "lbfgsb",
        "alpha_g": 3.0,
        "max_iterations": 200,
    }


@pytest.mark.parametrize(
    "text, message",
    [
        ("bad name=alpha_g=1", "the name must be"),
        ("v=alpha_q=1", "unknown option 'alpha_q'"),
        ("v=seed=3", "unknown option 'seed'"),
        ("v=alpha_g=many", "alpha_g must be a float"),
        ("v=per_step_weights=yes", "per_step_weights must be true or false"),
        ("v=alpha_g=-1", "alpha_n, alpha_g and alpha_w must be finite and >= 0"),
    ],
)
def test_bad_variants_are_refused_with_a_reason(text, message):
    with pytest.raises(ValueError, match=message):
        study_variants.parse_variant(text)


def test_study_sets_are_training_and_validation_sets_only():
    for _bags, sets, kind in study_variants.TASKS.values():
        assert all(name.endswith(("_train", "_val")) for name in sets)
        assert kind in ("grasp", "open_box")


def test_the_summary_gives_each_group_and_the_mean_min_max():
    rows = [
        {
            "variant": "v",
            "task": "box",
            "seed": seed,
            "model": {key: -0.5 - 0.1 * seed for key in study_variants.MODEL_MEASURES},
            "sets": {"box_val": {"opened": opened, "episodes": 25, "good_converged": seed}},
        }
        for seed, opened in enumerate((20, 23, 17))
    ]
    text = study.seed_summary(rows)
    assert (
        "v / box over 3 groups" in text
        and "box_val opened 20/23/17 (mean 20, min 17, max 23)" in text
        and "box_val at rest 0/1/2 (mean 1, min 0, max 2)" in text
        and "cosine_weighted -0.5/-0.6/-0.7 (mean -0.6, min -0.7, max -0.5)" in text
    )


def test_selection_settings_are_variant_options_checked_as_a_training_checks_them():
    name, changes = study_variants.parse_variant("s8n3=candidates=8,members=3,score=judge")
    assert changes == {"candidates": 8, "members": 3, "score": "judge"}
    assert study_variants.training_part(changes) == {}
    assert study_variants.selection_part(changes) == changes
    with pytest.raises(
        ValueError, match=r"variant 's': members must be in \[1, candidates \(2\)\]"
    ):
        study_variants.parse_variant("s=candidates=2,members=3")
    with pytest.raises(ValueError, match="variant 's': the selection score must be one of"):
        study_variants.parse_variant("s=score=luck")


def test_rho_scale_is_a_controller_option_passed_to_the_objective():
    name, changes = study_variants.parse_variant("r=rho_scale=3")
    assert changes == {"rho_scale": 3.0} and study_variants.training_part(changes) == {}
    assert study_measures.controller_options(changes, "sphere", RobotModel()) == {"rho_scale": 3.0}
    with pytest.raises(ValueError, match="rho_scale must be in"):
        study_variants.parse_variant("r=rho_scale=0")


def test_the_fall_pace_is_a_controller_option_given_by_its_knee():
    name, changes = study_variants.parse_variant("p=fall_pace=0.25")
    assert changes == {"fall_pace": 0.25} and study_variants.training_part(changes) == {}
    options = study_measures.controller_options(changes, "sphere", RobotModel())
    assert options == {"fall_pace_knee": 0.25}
    _, off = study_variants.parse_variant("paper=fall_pace=0")
    assert study_measures.controller_options(off, "sphere", RobotModel()) == {"fall_pace_knee": 0}
    for bad in ("-0.1", "1.5"):
        with pytest.raises(ValueError, match="fall_pace"):
            study_variants.parse_variant(f"p=fall_pace={bad}")


def test_the_stall_escape_is_a_controller_option_given_by_its_walks():
    name, changes = study_variants.parse_variant("e=stall_escapes=0")
    assert changes == {"stall_escapes": 0} and study_variants.training_part(changes) == {}
    assert study_measures.controller_options(changes, "box", RobotModel()) == {"stall_escapes": 0}
    with pytest.raises(ValueError, match="stall_escapes must be >= 0"):
        study_variants.parse_variant("e=stall_escapes=-1")


def test_controller_settings_are_variant_options_that_do_not_change_the_training():
    name, changes = study_variants.parse_variant("grip=alpha_g=10,hand_lead=0.2,grasp_steps=1500")
    assert changes == {"alpha_g": 10.0, "hand_lead": 0.2, "grasp_steps": 1500}
    assert study_variants.training_part(changes) == {"alpha_g": 10.0}
    with pytest.raises(ValueError, match="hand_lead must be >= 0 rad"):
        study_variants.parse_variant("v=hand_lead=-0.1")


def test_contact_options_change_the_task_s_contact_rules_only_where_given():
    _, changes = study_variants.parse_variant(
        "c=grasp_cushion=0.0,lid_beneath_only=false,lid_depth=0.01"
    )
    assert changes == {"grasp_cushion": 0.0, "lid_beneath_only": False, "lid_depth": 0.01}
    assert study_variants.training_part(changes) == {}
    grasp = study_measures.contact_rules(changes, "grasp")["object"]
    assert grasp.cushion == 0.0 and grasp.depth == TASK_CONTACTS["grasp"]["target"].depth
    lid = study_measures.contact_rules(changes, "open_box")["lid"]
    assert lid.side is None and lid.depth == 0.01
    assert study_measures.contact_rules({"hand_lead": 0.1}, "grasp") is None
    assert study_measures.contact_rules({"grasp_depth": 0.0}, "open_box") is None
    with pytest.raises(ValueError, match="contact depths and cushions must be in"):
        study_variants.parse_variant("v=grasp_depth=0.2")


def test_the_domain_damper_can_be_left_out_for_a_study():
    from tric_control.limits import DomainDamper
    from tric_control.motion_rate import default_limits
    from tric_sim.world.robot_model import RobotModel

    assert study_variants.parse_variant("v=domain_damper=false")[1] == {"domain_damper": False}
    robot = RobotModel()
    kinds = [type(limit) for limit in default_limits(robot, {}, domain_damper=False)]
    assert DomainDamper not in kinds and len(kinds) == len(default_limits(robot, {})) - 1


def test_tric_study_checks_its_results_file_before_any_training(tmp_path, capsys):
    """study.json that is a folder is refused with one line before a model is trained."""
    (tmp_path / "study.json").mkdir()
    assert study.main(["--out", str(tmp_path), "--tasks", "sphere", "--seeds", "0"]) == 2
    assert capsys.readouterr().err == (
        f"tric-study: study file {tmp_path / 'study.json'} is a folder; give a file path\n"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.json"]


def test_variant_names_are_checked_before_any_work(tmp_path, capsys, monkeypatch):
    """A variant name of 300 characters passed, trained for about 50 s, then failed on its
    model's file name; a name given twice mixed two variants' rows; names its models' file names
    make one file (as a case-insensitive file system compares them) are refused too."""
    from tric_sim.tools import file_names

    out = tmp_path / "study"
    base = ["--tasks", "sphere", "--seeds", "0", "--out", str(out), "--executor", "processes"]
    refusals = [
        (["--variant", "v" * 300 + "=max_iterations=2"], "the name is 300 characters long"),
        (["--variant", "a=max_iterations=2", "--variant", "a="], "variant 'a' is given twice"),
    ]
    for variants, message in refusals:
        assert study.main([*variants, *base]) == 2
        error = capsys.readouterr().err
        assert message in error and error.count("\n") == 1
    monkeypatch.setattr(file_names, "name_folding", lambda folder: (True, False))
    assert study.main(["--variant", "Tiny=", "--variant", "tiny=", *base]) == 2
    assert "the models of 'Tiny/sphere/0' and 'tiny/sphere/0' would be one file" in (
        capsys.readouterr().err
    )
    assert list(tmp_path.iterdir()) == []


def test_stale_rows_are_named_with_what_changed():
    from tric_control.study.staleness import key_changes, stale_line

    model = {"data_digest": "b", "training_code": "t", "alpha_g": 3.0, "seed": 0}
    candidate = {
        "model": model,
        "controller": {},
        "max_steps": 800,
        "rollout_code": "r",
        "episode_code": "e",
    }
    key = {
        "candidates": [candidate, {**candidate, "model": {**model, "seed": 1}}],
        "selection": {"candidates": 2, "members": 1, "score": "landmarks"},
        "every_candidate": False,
        "sets": ["sphere_val"],
        "choice_code": "c",
    }
    assert key_changes(key, key) == ""

    def each(**changes):
        return [{**c, **changes} for c in key["candidates"]]

    changed = {
        **key,
        "candidates": [
            {**c, "episode_code": "f", "model": {**c["model"], "data_digest": "c"}}
            for c in key["candidates"]
        ],
    }
    assert key_changes(changed, key) == "the episodes' code changed, the bags changed"
    retrained = {
        **key,
        "candidates": [{**c, "model": {**c["model"], "alpha_g": 1.0}} for c in key["candidates"]],
    }
    assert key_changes(retrained, key) == "the training options changed"
    rechosen = {**key, "selection": {**key["selection"], "score": "judge"}}
    assert key_changes(rechosen, key) == "the selection changed"
    assert key_changes({**key, "candidates": each(max_steps=500)}, key) == (
        "the step budget changed"
    )
    assert key_changes({**key, "candidates": key["candidates"][:1]}, key) == (
        "the number of candidates changed"
    )
    assert key_changes({"candidates": [{"model": "x"}]}, key).startswith(
        "its candidates' keys are missing"
    )
    assert key_changes(None, key) == "kept without a key"
    assert (
        stale_line(["a/sphere/0 (x)"])
        == "1 kept row made otherwise, measured again: a/sphere/0 (x)"
    )


def test_a_candidates_training_key_names_the_rollout_code_only_with_hard_negatives():
    """Without rounds of hard negatives a candidate is training code alone: an edit of the
    controller or the episodes keeps its key (and its model); with rounds, their code is named."""
    from tric_control.study.candidates import training_key
    from tric_learning.training.value import TrainingConfig
    from tric_sim.tools.provenance import code_digest

    training = code_digest("tric_learning.training.value")
    rolling = code_digest("tric_learning.training.value", "tric_control.study.hard_negatives")
    assert training != rolling
    assert training_key(TrainingConfig(), "d")["training_code"] == training
    with_rounds = training_key(TrainingConfig(), "d", rounds=2, max_steps=800)
    assert with_rounds["training_code"] == rolling and with_rounds["hard_negative_rounds"] == 2
