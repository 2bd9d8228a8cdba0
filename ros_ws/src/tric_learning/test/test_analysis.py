"""The model analyses of tric_learning.analysis (paper Fig. 12 to 17) on hand-made value functions
and demonstrations, where every number is known: features y = q (identity Jacobians), so
grad_q (f o phi) = df/dy; and, for Fig. 14b, a sphere put where the hand's distance to it is
known."""

import warnings
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

from tric_learning import analysis, analyze_cli
from tric_learning.features import FeatureDefinition
from tric_learning.training.dataset import Dataset, Demo
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world import scene, situations
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def demo(name: str, q) -> Demo:
    """A demo whose features are its joints (y = q, dy/dq = I)."""
    q = np.asarray(q, dtype=float)
    return Demo(
        name=name,
        situation=None,
        q=q,
        y=q.copy(),
        jacobians=np.repeat(np.eye(q.shape[1])[None], len(q), 0),
        object_poses=[{}] * len(q),
        stamps_ns=np.arange(len(q)),
    )


def dataset(*demos) -> Dataset:
    """The demos with two named features (no feature definition is needed beyond the names)."""
    return Dataset(SimpleNamespace(task="grasp", feature_names=("a", "b")), list(demos))


def linear(w3, low=None, high=None) -> ValueFunction:
    """f = w3 . u with u = (y - low) / (high - low) on every feature (K = 0)."""
    w3 = np.asarray(w3, dtype=float)
    low = np.zeros(len(w3)) if low is None else np.asarray(low, dtype=float)
    high = np.ones(len(w3)) if high is None else np.asarray(high, dtype=float)
    return ValueFunction(
        Scaling(np.arange(len(w3)), low, high, len(w3)), np.zeros((0, len(w3))), np.zeros(0), w3
    )


def test_cosines_on_straight_lines_against_along_and_across_the_gradient():
    model = linear([1.0, 2.0])  # grad f = (1, 2) everywhere
    # the last step rests
    down = demo("down", [[0.0, 0.0], [-0.05, -0.1], [-0.15, -0.3], [-0.15, -0.3]])
    # (0.2, -0.1) is orthogonal
    up_then_across = demo("up", [[0.0, 0.0], [0.05, 0.1], [0.25, 0.0]])
    cosines = analysis.cosines_along_demos(model, dataset(down, up_then_across))
    assert cosines.shape == (2, 3)
    np.testing.assert_allclose(cosines[0, :2], [-1.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(cosines[1, :2], [1.0, 0.0], atol=1e-12)
    # a zero step; past the shorter demo's end
    assert np.isnan(cosines[0, 2]) and np.isnan(cosines[1, 2])
    moving = analysis.cosines_along_demos(model, dataset(down, up_then_across), min_step=0.15)
    # |(0.05, 0.1)| < 0.15 < |(0.1, 0.2)|
    assert np.isnan(moving[0, 0]) and moving[0, 1] == pytest.approx(-1.0)
    assert np.isnan(moving[1, 0]) and moving[1, 1] == pytest.approx(0.0, abs=1e-12)


def test_cosines_use_the_recorded_jacobian_and_the_scaling():
    model = linear([1.0, 0.0], low=[0.0, 0.0], high=[4.0, 1.0])  # df/dy = (1/4, 0)
    rotated = demo("rotated", [[0.0, 0.0], [0.0, -0.3]])
    rotated.jacobians[0] = [[0.0, 1.0], [-1.0, 0.0]]  # y_0 = q_1: grad_q = (0, 1/4)
    cosines = analysis.cosines_along_demos(model, dataset(rotated))
    assert cosines[0, 0] == pytest.approx(-1.0)


def test_gradients_along_demos_are_constant_for_a_linear_model_and_known_for_one_unit():
    gradients = analysis.gradients_along_demos(
        linear([1.0, -2.0], high=[2.0, 1.0]),
        dataset(
            demo("long", [[0.0, 0.0], [0.5, 0.1], [1.0, 0.2]]),
            demo("short", [[0.3, 0.3], [0.1, 0.2]]),
        ),
    )
    assert gradients.shape == (2, 3, 2)
    # df/du = W3 (the paper's K = 0 remark)
    np.testing.assert_allclose(gradients[0], [[1.0, -2.0]] * 3)
    np.testing.assert_allclose(gradients[1, :2], [[1.0, -2.0]] * 2)
    assert np.all(np.isnan(gradients[1, 2]))
    one_unit = ValueFunction(
        Scaling(np.arange(2), np.zeros(2), np.ones(2), 2),
        np.array([[1.0, 0.0]]),
        np.array([2.0]),
        np.array([1.0, -2.0]),
    )
    [[at_zero]] = analysis.gradients_along_demos(one_unit, dataset(demo("zero", [[0.0, 0.0]])))
    np.testing.assert_allclose(at_zero, [1.0 + 2.0 * 0.25, -2.0])  # W3 + W1^T (W2 sigmoid'(0))


def test_mean_over_demos_skips_missing_entries_without_warning():
    values = np.array([[1.0, np.nan, 2.0], [3.0, np.nan, np.nan]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mean = analysis.mean_over_demos(values)
    np.testing.assert_allclose(mean, [2.0, np.nan, 2.0])
    np.testing.assert_allclose(analysis.mean_over_demos(np.ones((2, 3, 4))), np.ones((3, 4)))


def test_key_numbers_of_a_model_that_explains_one_demo_and_not_another():
    model = linear([1.0, 2.0])
    good = demo("good", [[0.0, 0.0], [-0.1, -0.2], [-0.2, -0.4], [-0.2, -0.4]])
    bad = demo("bad", [[0.0, 0.0], [0.1, 0.2], [0.2, 0.4], [0.2, 0.4]])
    numbers = analysis.key_numbers(model, dataset(good, bad), top=1)
    assert (
        numbers["steps"] == 6
        and numbers["moving_steps"] == 4
        and numbers["demos_ending_lower"] == 1
    )
    assert numbers["falls"] == pytest.approx(0.5)
    assert numbers["falls_moving"] == pytest.approx(0.5)
    # two -1 and two +1, of equal lengths
    assert numbers["cosine_moving"] == pytest.approx(0.0, abs=1e-12)
    assert numbers["cosine_weighted"] == pytest.approx(0.0, abs=1e-12)
    assert numbers["slow_steps"] == 0 and np.isnan(numbers["cosine_slow"])
    # both rest at the end
    assert numbers["late_from_step"] == 2 and np.isnan(numbers["cosine_moving_late"])
    assert numbers["kept_features"] == 2 and numbers["selected_features"] == 2
    # scores 1 and 2: the larger alone carries 2/3 of the total, both 95%
    assert numbers["features_95"] == 2
    assert numbers["top_features"] == [{"name": "b", "score": 2.0}]
    assert numbers["top_gradients_changing_sign"] == 0


def test_gradient_measures_weigh_each_step_by_its_length_and_filter_nothing_from_the_training():
    """grad f = (1, 0): a long step straight down f (cosine -1, 0.2 rad), a slow one across
    (cosine 0, 0.01 rad), a slow one up (cosine +1, 0.02 rad) and one that barely moves (0.0005
    rad, down f): the weighted mean is (-0.2 + 0.02 - 0.0005) / 0.2305, the plain mean over the
    steps that move at all (> 1e-3 rad) (-1 + 0 + 1) / 3, the slow steps' mean (0 + 1) / 2, and f
    falls on 1 of the 3 steps of at least 0.01 rad and 1 of the 3 that move."""
    model = linear([1.0, 0.0])
    path = demo(
        "mixed",
        [[0.3, 0.0], [0.1, 0.0], [0.1, 0.01], [0.12, 0.01], [0.1195, 0.01]],
    )
    measures = analysis.gradient_measures(model, dataset(path))
    assert measures["cosine_weighted"] == pytest.approx((-0.2 + 0.02 - 0.0005) / 0.2305)
    assert measures["cosine_moving"] == pytest.approx(0.0, abs=1e-12)
    assert measures["cosine_slow"] == pytest.approx(0.5) and measures["slow_steps"] == 2
    assert measures["falls"] == pytest.approx(1 / 3)
    assert measures["falls_moving"] == pytest.approx(1 / 3)


def test_features_carrying_a_share_of_the_weight():
    scores = linear([5.0, -3.0, 1.0, 1.0])  # |W3|: 5, 3, 1, 1 of 10
    assert analysis.features_carrying(scores, 0.5) == 1
    assert analysis.features_carrying(scores, 0.8) == 2
    assert analysis.features_carrying(scores, 0.95) == 4
    assert analysis.features_carrying(linear([0.0, 0.0])) == 0


def test_score_order_and_a_gradient_that_changes_sign():
    # f = u_0 - 4 sigmoid(4 u_0) + 0.1 u_1: df/du_0 = 1 - 16 sigmoid'(4 u_0), < 0 at u_0 = 0, > 0 at
    # u_0 = 1
    model = ValueFunction(
        Scaling(np.arange(2), np.zeros(2), np.ones(2), 2),
        np.array([[4.0, 0.0]]),
        np.array([-4.0]),
        np.array([1.0, 0.1]),
    )
    np.testing.assert_array_equal(analysis.score_order(model), [0, 1])
    numbers = analysis.key_numbers(
        model, dataset(demo("along", [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]])), 2
    )
    assert numbers["top_gradients_changing_sign"] == 1


def test_figures_are_written(tmp_path):
    model = linear([1.0, 2.0])
    demos = dataset(
        demo("one", [[0.0, 0.0], [-0.1, -0.2], [-0.2, -0.3]]),
        demo("two", [[0.1, 0.0], [0.0, -0.1]]),
    )
    paths = analysis.write_figures(model, demos, tmp_path / "figures", top=2, feature_rank=2)
    assert [path.name for path in paths] == [
        analysis.VALUE_FIGURE,
        analysis.COSINES_FIGURE,
        analysis.SCORES_FIGURE,
        analysis.GRADIENTS_FIGURE,
        analysis.KERNEL_PCA_FIGURE,
        analysis.FEATURE_FIGURE,
    ]
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def box_dataset(robot, count: int = 2, steps: int = 4) -> Dataset:
    """count box demos of the real open_box definition: the hand moves from home, the recorded
    features are random (Fig. 12 only reads them), the lid closed."""
    definition = FeatureDefinition.for_task("open_box", robot)
    generator = np.random.default_rng(0)
    demos = []
    for situation in situations.dataset("box_train")[:count]:
        hinge = scene.hinge_placement(situation)
        poses = {
            "object": (situation.object_position, situation.object_orientation),
            "lid": scene.pose_tuple(hinge),
            "lid_edge": scene.pose_tuple(
                hinge * scene.lid_edge_offset(situation.object_dimensions[0])
            ),
        }
        q = robot.home + np.linspace(0.0, 0.3, steps)[:, None] * np.eye(robot.n_joints)[1]
        demos.append(
            Demo(
                situation.name,
                situation,
                q,
                generator.random((steps, definition.size)),
                np.zeros((steps, definition.size, robot.n_joints)),
                [poses] * steps,
                np.arange(steps),
            )
        )
    return Dataset(definition, demos)


def test_every_figure_of_box_demos_is_written(tmp_path, robot):
    demos = box_dataset(robot)
    model = linear(np.linspace(1.0, 2.0, demos.definition.size))
    paths = analysis.write_figures(model, demos, tmp_path, top=5, robot=robot)
    assert [path.name for path in paths][-2:] == [
        analysis.TASK_SPACES_FIGURE,
        analysis.COLLISION_FIGURE,
    ]
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_feature_paths_are_the_recorded_relative_positions(robot):
    demos = box_dataset(robot, count=3)
    names = list(demos.definition.feature_names)
    paths = analysis.feature_paths(demos, "fingertip_2", "box", count=2)
    assert len(paths) == 2 and paths[0].shape == (4, 3)
    column = names.index("p[fingertip_2->box].y")
    np.testing.assert_array_equal(paths[1][:, 1], demos.demos[1].y[:, column])
    with pytest.raises(ValueError, match=r"p\[fingertip_1->box\]"):
        analysis.feature_paths(demos, "fingertip_1", "box")


def test_joint_principal_paths_keep_the_geometry_of_a_three_dimensional_motion():
    generator = np.random.default_rng(1)
    # 3 orthonormal directions in R^6
    basis = np.linalg.qr(generator.normal(size=(6, 3)))[0].T
    demos = [demo(f"d{k}", generator.normal(size=(5, 3)) @ basis + 0.5) for k in range(3)]
    paths, share = analysis.joint_principal_paths(Dataset(SimpleNamespace(), demos), count=2)
    assert len(paths) == 2 and share.sum() == pytest.approx(1.0)
    assert np.all(np.diff(share) <= 0)
    original = np.concatenate([d.q for d in demos[:2]])
    projected = np.concatenate(paths)
    gaps = lambda x: np.linalg.norm(x[:, None] - x[None], axis=2)  # noqa: E731
    np.testing.assert_allclose(gaps(projected), gaps(original), atol=1e-12)


def sphere_at(robot, position, radius: float) -> Demo:
    """A one-sample grasp demo at home with a sphere of radius at position (world): its recorded
    pose, wherever the situation put it."""
    situation = situations.sphere("probe", (0.5, 0.0, 0.3), radius=radius)
    poses = {"object": (tuple(position), (0.0, 0.0, 0.0, 1.0))}
    return Demo(
        "probe",
        situation,
        robot.home[None],
        np.zeros((1, 2)),
        np.zeros((1, 2, robot.n_joints)),
        [poses],
        np.arange(1),
    )


def test_hand_distances_to_a_sphere_in_the_palm_and_far_above(robot):
    robot.forward(robot.home)
    palm = robot.frame_placement(robot.profile.palm).translation
    inside = analysis.hand_body_distances(robot, Dataset(None, [sphere_at(robot, palm, 0.03)]))
    assert inside[0][0, 0] < 0 and inside[1][0, 0] >= 1 and inside[2] == "target"
    above = palm + np.array([0.0, 0.0, 1.0])
    (small,), (count,), _ = analysis.hand_body_distances(
        robot, Dataset(None, [sphere_at(robot, above, 0.03)])
    )
    (large,), _, _ = analysis.hand_body_distances(
        robot, Dataset(None, [sphere_at(robot, above, 0.13)])
    )
    assert 0.7 < small[0] < 1.0 and count[0] == 0
    # a sphere's distance falls with its radius
    assert small[0] - large[0] == pytest.approx(0.10, abs=1e-6)
    # the pairs within the influence distance: none just below the smallest distance, one or more
    # above it
    probe = Dataset(None, [sphere_at(robot, above, 0.03)])
    assert analysis.hand_body_distances(robot, probe, influence=small[0] - 1e-4)[1][0, 0] == 0
    assert analysis.hand_body_distances(robot, probe, influence=small[0] + 1e-4)[1][0, 0] >= 1


def test_hand_distances_to_a_lid_follow_its_pose(robot):
    demos = box_dataset(robot, count=1, steps=1)
    closed = analysis.hand_body_distances(robot, demos)
    robot.forward(robot.home)
    tip = robot.frame_placement("finger_2_tip").translation
    poses = demos.demos[0].object_poses[0]
    side = demos.demos[0].situation.object_dimensions[0]
    # the lid's hinge frame moved so that the plate's centre is at fingertip 2
    moved = pin.SE3(np.eye(3), tip) * scene.lid_geometry_offset(side).inverse()
    demos.demos[0].object_poses[0] = {**poses, "lid": scene.pose_tuple(moved)}
    touching = analysis.hand_body_distances(robot, demos)
    assert closed[2] == touching[2] == "lid"
    assert closed[0][0, 0] > 0.05 and touching[0][0, 0] < 0


def test_kernel_pca_bandwidth_centring_and_clusters():
    points = np.array([[0.0, 0.0], [0.1, 0.0], [0.0, 0.1], [5.0, 5.0], [5.1, 5.0], [5.0, 5.1]])
    projected, bandwidth = analysis.kernel_pca(points)
    gaps = np.linalg.norm(points[:, None] - points[None], axis=2)[np.triu_indices(6, 1)]
    assert bandwidth == pytest.approx(np.median(gaps))
    assert projected.shape == (6, 2)
    np.testing.assert_allclose(projected.sum(axis=0), 0.0, atol=1e-9)  # a centred kernel
    first = projected[:, 0]
    assert np.sign(first[:3]).tolist() == [np.sign(first[0])] * 3 and np.all(
        first[:3] * first[3:] < 0
    )
    assert np.abs(first).max() == first.max()  # the sign convention
    same, bandwidth = analysis.kernel_pca(np.ones((4, 3)))
    assert bandwidth == 1.0 and np.allclose(same, 0.0)


def test_kernel_pca_inputs_hidden_layer_and_values():
    model = ValueFunction(
        Scaling(np.arange(2), np.zeros(2), np.ones(2), 2),
        np.array([[2.0, 0.0]]),
        np.array([3.0]),
        np.array([1.0, -1.0]),
    )
    demos = dataset(
        demo("one", [[0.0, 0.0], [0.5, 0.25], [1.0, 1.0]]), demo("two", [[0.2, 0.1], [0.3, 0.3]])
    )
    inputs = analysis.kernel_pca_inputs(model, demos)
    assert inputs["u"].shape == (5, 2) and inputs["z"].shape == (5, 1)
    np.testing.assert_allclose(inputs["z"][:, 0], 1.0 / (1.0 + np.exp(-2.0 * inputs["u"][:, 0])))
    np.testing.assert_allclose(
        inputs["value"], model.value(np.concatenate([d.y for d in demos.demos]))
    )
    assert inputs["last"].tolist() == [False, False, True, False, True]
    subsampled = analysis.kernel_pca_inputs(model, demos, limit=2)
    assert subsampled["last"].sum() == 2 and len(subsampled["u"]) <= 4
    # K = 0: no hidden layer
    assert analysis.kernel_pca_inputs(linear([1.0, 1.0]), demos)["z"] is None


def test_relative_spread():
    points = np.array([[0.0, 0.0], [2.0, 0.0], [10.0, 0.0], [12.0, 0.0]])
    assert analysis.relative_spread(points, np.array([True, True, False, False])) == pytest.approx(
        1.0 / np.sqrt(26.0)
    )


def test_feature_over_time_picks_the_ranked_feature():
    model = linear([1.0, -3.0], high=[2.0, 1.0])  # scores 1 and 3: "b" first
    demos = dataset(
        demo("long", [[0.0, 0.5], [0.5, 0.4], [1.0, 0.3]]), demo("short", [[0.3, 0.3], [0.1, 0.2]])
    )
    values, gradients, name = analysis.feature_over_time(model, demos, 2)
    assert name == "a"
    np.testing.assert_allclose(values[0], [0.0, 0.5, 1.0])
    np.testing.assert_allclose(values[1, :2], [0.3, 0.1])
    assert np.isnan(values[1, 2]) and np.isnan(gradients[1, 2])
    # df/du = W3 of the linear model
    np.testing.assert_allclose(gradients[0], [1.0] * 3)
    assert analysis.feature_over_time(model, demos, 1)[2] == "b"
    with pytest.raises(ValueError, match="keeps 2 features"):
        analysis.ranked_feature(model, ("a", "b"), 3)


def test_the_command_refuses_a_feature_rank_before_any_work(tmp_path, capsys):
    assert (
        analyze_cli.main(
            ["model.safetensors", "bags", "--out", str(tmp_path / "x"), "--feature-rank", "0"]
        )
        == 2
    )
    assert "--feature-rank must be at least 1" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
