"""The numbers behind the paper's analyses of a trained TRIC model, from its demonstrations: f
and L_g's cosines along them, df/dy by step, the feature scores, the hand's distances to the body
it may touch (the collision prior), kernel PCA of y and z, and the key numbers the tools print."""

import coal
import numpy as np
import pinocchio as pin

from tric_learning.training.dataset import Dataset
from tric_learning.training.value import SELECTED_FRACTION
from tric_learning.value_function import ValueFunction
from tric_sim.world.collision import SceneCollision
from tric_sim.world.robot_model import RobotModel

#: The step classes of the gradient measures, rad (|q_{t+1} - q_t|), fixed by the design (section 5)
#: and issue 24 before any change of the training, and independent of any rule the training uses: a
#: step that moves at all; the slow steps (a grasp's final approach, a lid lifting); the steps along
#: which f must fall.
MOVING_STEP = 1e-3
SLOW_STEPS = (0.005, 0.03)
FALLING_STEP = 0.01
#: The share of the total feature score (Sec. 5.5.1) that the counted features carry.
WEIGHT_SHARE = 0.95

#: Box openings drawn in Fig. 12 (the paper's 5), and the landmarks of its panels (b) and (c).
FIG12_DEMOS = 5


FIG12_FINGER, FIG12_OBJECT = "fingertip_2", "box"


#: The controller's influence distance, m: the collision pairs nearer than this enter its QP
#: (tric_control.motion_rate.INFLUENCE, which tric_learning may not import; a test keeps them
#: equal).
CONTROLLER_INFLUENCE = 0.05


#: The scene bodies the hand may touch (tric_sim.world.scene roles): Fig. 14b's distances are
#: to these.
TOUCHED_ROLES = ("target", "lid")


#: Kernel PCA on at most this many samples (evenly spaced over the demonstrations' samples): its
#: eigendecomposition grows with the cube of the count.
KPCA_MAX_SAMPLES = 2000


#: Fig. 17b/c show the feature of this rank by score, unless --feature-rank says otherwise.
DEFAULT_FEATURE_RANK = 8


def values_along_demos(model: ValueFunction, dataset: Dataset) -> list:
    """f(y_t) of each demo, [(T,)] in dataset order."""
    return [model.value(demo.y) for demo in dataset.demos]


def step_lengths(dataset: Dataset) -> np.ndarray:
    """|q_{t+1} - q_t| of every step, (N, T_max - 1) rad for N demos of at most T_max samples, NaN
    past a demo's end."""
    return padded([np.linalg.norm(np.diff(demo.q, axis=0), axis=1) for demo in dataset.demos])


def value_falls(model: ValueFunction, dataset: Dataset) -> np.ndarray:
    """Whether f falls along each step, f(y_{t+1}) < f(y_t): (N, T_max - 1) of 1.0 / 0.0, NaN past
    a demo's end."""
    return padded(
        [(np.diff(values) < 0).astype(float) for values in values_along_demos(model, dataset)]
    )


def cosines_along_demos(
    model: ValueFunction, dataset: Dataset, min_step: float = 0.0
) -> np.ndarray:
    """L_g's cosine (Eq. 17) between grad_q (f o phi)(q_t) = (df/dy)(y_t) dphi/dq(q_t) and the step
    q_{t+1} - q_t, (N, T_max - 1) for N demos of at most T_max samples: NaN past a demo's end, where
    the step is shorter than min_step rad or is zero, and where the gradient is zero."""
    longest = max(demo.length for demo in dataset.demos)
    cosines = np.full((len(dataset.demos), longest - 1), np.nan)
    for i, demo in enumerate(dataset.demos):
        steps = np.diff(demo.q, axis=0)
        gradients = np.array(
            [model.gradient(y)[1] @ jacobian for y, jacobian in zip(demo.y[:-1], demo.jacobians)]
        )
        step_norms = np.linalg.norm(steps, axis=1)
        norms = step_norms * np.linalg.norm(gradients, axis=1)
        defined = np.flatnonzero((step_norms >= min_step) & (norms > 0))
        cosines[i, defined] = (
            np.einsum("tn,tn->t", gradients[defined], steps[defined]) / norms[defined]
        )
    return cosines


def moving_only(cosines: np.ndarray, dataset: Dataset) -> np.ndarray:
    """cosines (N, T_max - 1) from cosines_along_demos() with NaN where the step moves by
    MOVING_STEP rad or less."""
    return np.where(step_lengths(dataset) > MOVING_STEP, cosines, np.nan)


def gradient_measures(model: ValueFunction, dataset: Dataset) -> dict:
    """How well grad_q (f o phi) follows the demonstrations, over every step of every demo with no
    filter from the training (step classes: MOVING_STEP, SLOW_STEPS, FALLING_STEP):

    cosine_weighted: L_g's cosine averaged with each step's length |dq| as its weight;
    cosine_moving: its plain mean over the steps that move at all (> MOVING_STEP rad);
    cosine_slow: its mean over the slow steps (SLOW_STEPS, rad), and slow_steps their count;
    falls: the share of the steps of at least FALLING_STEP rad along which f falls, and
    falls_moving the same over the steps that move at all.
    NaN where a class has no step."""
    cosines = cosines_along_demos(model, dataset)
    lengths = step_lengths(dataset)
    falls = value_falls(model, dataset)
    defined = np.isfinite(cosines)
    weights = np.where(defined, lengths, 0.0)
    moving = lengths > MOVING_STEP
    slow = (lengths >= SLOW_STEPS[0]) & (lengths < SLOW_STEPS[1])

    def mean(values, where):
        chosen = values[where & np.isfinite(values)]
        return float(chosen.mean()) if chosen.size else float("nan")

    return {
        "cosine_weighted": float(np.sum(np.where(defined, cosines, 0.0) * weights) / weights.sum())
        if weights.sum() > 0
        else float("nan"),
        "cosine_moving": mean(cosines, moving),
        "cosine_slow": mean(cosines, slow),
        "slow_steps": int(np.sum(slow)),
        "falls": mean(falls, lengths >= FALLING_STEP),
        "falls_moving": mean(falls, moving),
    }


def features_carrying(model: ValueFunction, share: float = WEIGHT_SHARE) -> int:
    """The fewest kept features whose scores s(y) (Sec. 5.5.1) add up to share of the total (0 for
    a model whose scores are all zero)."""
    scores = np.sort(model.scores())[::-1]
    total = scores.sum()
    if not total > 0:
        return 0
    return int(np.searchsorted(np.cumsum(scores), share * total * (1 - 1e-12)) + 1)


def gradients_along_demos(model: ValueFunction, dataset: Dataset) -> np.ndarray:
    """df/du at every sample, u the kept features rescaled to [0, 1] (the paper's y):
    (N, T_max, s) for N demos of at most T_max samples, NaN past a demo's end."""
    longest = max(demo.length for demo in dataset.demos)
    gradients = np.full((len(dataset.demos), longest, len(model.scaling.kept)), np.nan)
    for i, demo in enumerate(dataset.demos):
        for t, u in enumerate(model.scaling.transform(demo.y)):
            gradients[i, t] = model.scaled_gradient(u)[1]
    return gradients


def mean_over_demos(values: np.ndarray) -> np.ndarray:
    """The mean over the first axis (demos) of the finite entries of values (N, ...), (...); NaN
    where no demo has one (e.g. past every demo's end)."""
    counts = np.sum(np.isfinite(values), axis=0)
    sums = np.nansum(values, axis=0)
    return np.divide(sums, counts, out=np.full(sums.shape, np.nan), where=counts > 0)


def score_order(model: ValueFunction) -> np.ndarray:
    """Indices into the kept features, highest score s(y) first, (s,)."""
    return np.argsort(-model.scores(), kind="stable")


def ranked_features(model: ValueFunction, feature_names) -> list:
    """[(name, score)] of the kept features, highest score s(y) first."""
    scores = model.scores()
    names = np.asarray(feature_names)[model.scaling.kept]
    return [(str(names[k]), float(scores[k])) for k in score_order(model)]


def padded(arrays: list) -> np.ndarray:
    """Per-demo arrays [(T_i, ...)] stacked into (N, T_max, ...), NaN past each one's end."""
    longest = max(len(a) for a in arrays)
    out = np.full((len(arrays), longest) + np.shape(arrays[0])[1:], np.nan)
    for i, values in enumerate(arrays):
        out[i, : len(values)] = values
    return out


def feature_paths(dataset: Dataset, source: str, target: str, count: int = FIG12_DEMOS) -> list:
    """The recorded p[source->target] (the position of landmark target in source's frame, m) along
    the first count demos: [(T, 3)]; ValueError if the feature definition has no such features."""
    names = list(dataset.definition.feature_names)
    wanted = [f"p[{source}->{target}].{axis}" for axis in "xyz"]
    missing = [name for name in wanted if name not in names]
    if missing:
        raise ValueError(f"the feature definition has no {', '.join(missing)}")
    columns = [names.index(name) for name in wanted]
    return [demo.y[:, columns] for demo in dataset.demos[:count]]


def joint_principal_paths(dataset: Dataset, count: int = FIG12_DEMOS):
    """The first count demos' q projected on the first three principal components of all their
    samples (centred): ([(T, 3)] in rad, the share of q's variance each component explains (3,))."""
    demos = dataset.demos[:count]
    stacked = np.concatenate([demo.q for demo in demos])
    mean = stacked.mean(axis=0)
    _, singular, axes = np.linalg.svd(stacked - mean, full_matrices=False)
    variance = singular**2
    share = variance[:3] / variance.sum() if variance.sum() > 0 else np.zeros(3)
    components = np.zeros((3, stacked.shape[1]))
    components[: len(axes[:3])] = axes[:3]
    return [(demo.q - mean) @ components.T for demo in demos], np.pad(share, (0, 3 - len(share)))


def hand_geometries(robot: RobotModel) -> list:
    """Indices of the robot's collision geometries on the hand (its profile's hand_links)."""
    return [int(k) for k in np.flatnonzero(robot.hand_geometries)]


def hand_body_distances(
    robot: RobotModel, dataset: Dataset, influence: float = CONTROLLER_INFLUENCE
):
    """The controller's collision prior along the demos (paper Fig. 14b): at every sample, the
    smallest signed distance (m) between a hand geometry (hand_geometries) and the scene body the
    hand may touch (role in TOUCHED_ROLES: the grasp target, or the box's lid, where the sample's
    object poses put it), and how many hand geometries are nearer to it than influence (m). Returns
    (distances (N, T_max), counts (N, T_max), the body's role), NaN past a demo's end."""
    model, data = robot.model, robot.data
    geometry_model, geometry_data = robot.collision_model, robot.collision_data
    hand = hand_geometries(robot)
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    distances, counts, roles = [], [], set()
    for demo in dataset.demos:
        scene = SceneCollision(robot, demo.situation)
        touched = [k for k, body in enumerate(scene.bodies) if body.role in TOUCHED_ROLES]
        if not touched:
            raise ValueError(f"demo '{demo.name}': its scene has no body the hand may touch")
        body, shape = scene.bodies[touched[0]], scene.body_shapes[touched[0]]
        roles.add(body.role)
        demo_distances = np.empty((demo.length, len(hand)))
        for t, (q, poses) in enumerate(zip(demo.q, demo.object_poses)):
            pin.updateGeometryPlacements(model, data, geometry_model, geometry_data, q)
            placement = scene.body_placements(poses, [body])[0]
            other = coal.Transform3s(placement.rotation, placement.translation)
            for column, k in enumerate(hand):
                result.clear()
                world = geometry_data.oMg[k]
                demo_distances[t, column] = coal.distance(
                    geometry_model.geometryObjects[k].geometry,
                    coal.Transform3s(world.rotation, world.translation),
                    shape,
                    other,
                    request,
                    result,
                )
        distances.append(demo_distances.min(axis=1))
        counts.append(np.sum(demo_distances < influence, axis=1).astype(float))
    return padded(distances), padded(counts), "/".join(sorted(roles))


def kernel_pca(points: np.ndarray, components: int = 2):
    """Kernel PCA of points (S, k) with the Gaussian kernel exp(-|a - b|^2 / (2 h^2)), the bandwidth
    h the median distance between two of the points (the median heuristic; 1 if they all coincide):
    (the projections on the leading components (S, components), each sign fixed so that its
    largest entry is positive; h)."""
    points = np.asarray(points, dtype=float)
    squares = np.sum(points**2, axis=1)
    squared = np.maximum(squares[:, None] + squares[None, :] - 2.0 * points @ points.T, 0.0)
    between = np.sqrt(squared[np.triu_indices(len(points), 1)])
    bandwidth = float(np.median(between)) if len(between) else 0.0
    if not bandwidth > 0:
        bandwidth = 1.0
    kernel = np.exp(-squared / (2.0 * bandwidth**2))
    row_means = kernel.mean(axis=0)
    centred = kernel - row_means[:, None] - row_means[None, :] + row_means.mean()
    eigenvalues, eigenvectors = np.linalg.eigh(centred)
    order = np.argsort(eigenvalues)[::-1][:components]
    projections = eigenvectors[:, order] * np.sqrt(np.maximum(eigenvalues[order], 0.0))
    largest = projections[np.argmax(np.abs(projections), axis=0), np.arange(projections.shape[1])]
    return projections * np.where(largest < 0, -1.0, 1.0), bandwidth


def hidden_layer(model: ValueFunction, u: np.ndarray) -> np.ndarray:
    """z = sigmoid(W1 u) (Eq. 19) of scaled kept features u (..., s): (..., K)."""
    return 0.5 * (1.0 + np.tanh(0.5 * (np.asarray(u) @ model.w1.T + model.b1)))


def kernel_pca_inputs(
    model: ValueFunction, dataset: Dataset, limit: int = KPCA_MAX_SAMPLES
) -> dict:
    """Fig. 15's data on the demos' samples (at most limit of them evenly spaced, and every demo's
    last): the scaled kept features u (S, s), the hidden layer z (S, K) (None when K = 0), f (S,)
    and whether each sample is its demo's last (S,)."""
    u = model.scaling.transform(np.concatenate([demo.y for demo in dataset.demos]))
    last = np.zeros(len(u), dtype=bool)
    last[np.cumsum([demo.length for demo in dataset.demos]) - 1] = True
    chosen = np.unique(np.linspace(0, len(u) - 1, min(limit, len(u))).round().astype(int))
    chosen = np.union1d(chosen, np.flatnonzero(last)) if len(chosen) < len(u) else chosen
    u, last = u[chosen], last[chosen]
    value = u @ model.w3
    z = None
    if model.hidden_units:
        z = hidden_layer(model, u)
        value = value + z @ model.w2
    return {"u": u, "z": z, "value": value, "last": last}


def relative_spread(points: np.ndarray, subset: np.ndarray) -> float:
    """The RMS distance of the points selected by subset (mask) to their mean, divided by the same
    for all points (S, k): how compact a subset is within the whole."""

    def rms(values):
        return float(np.sqrt(np.mean(np.sum((values - values.mean(axis=0)) ** 2, axis=1))))

    whole = rms(points)
    return rms(points[subset]) / whole if whole > 0 else float("nan")


def ranked_feature(model: ValueFunction, feature_names, rank: int):
    """(index into the kept features, index into the raw features, name) of the feature ranked
    rank (1: the highest score s(y)); ValueError if there are fewer kept features."""
    kept = len(model.scaling.kept)
    if not 1 <= rank <= kept:
        raise ValueError(f"--feature-rank {rank}: the model keeps {kept} features (1 to {kept})")
    k = int(score_order(model)[rank - 1])
    raw = int(model.scaling.kept[k])
    return k, raw, str(feature_names[raw])


def feature_over_time(
    model: ValueFunction, dataset: Dataset, rank: int, gradients: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, str]:
    """Fig. 17b/c: the raw value (N, T_max) and df/du (N, T_max) (u: the feature rescaled to
    [0, 1]) of the feature ranked rank by score along every demo, NaN past a demo's end, and its
    name. gradients: gradients_along_demos(model, dataset) if already computed."""
    k, raw, name = ranked_feature(model, dataset.definition.feature_names, rank)
    if gradients is None:
        gradients = gradients_along_demos(model, dataset)
    return padded([demo.y[:, raw] for demo in dataset.demos]), gradients[:, :, k], name


def key_numbers(model: ValueFunction, dataset: Dataset, top: int) -> dict:
    """The analyses' numbers, JSON-ready: the demos and their steps t -> t + 1, and those that move
    at all (> MOVING_STEP rad); gradient_measures(); the demos that end lower than they start; the
    mean cosines of Fig. 14a over the moving steps before and from step late_from_step, 3/4 of the
    way; the kept features, the selected ones (score above SELECTED_FRACTION of the largest) and
    the fewest that carry WEIGHT_SHARE of the total score; the top features [{name, score}]; and how
    many of them have a mean gradient (Fig. 17a) that changes sign over time."""
    moving = moving_only(cosines_along_demos(model, dataset), dataset)
    late = int(round(0.75 * moving.shape[1]))
    ranked = ranked_features(model, dataset.definition.feature_names)
    scores = np.array([score for _, score in ranked])
    mean_gradient = mean_over_demos(gradients_along_demos(model, dataset))[
        :, score_order(model)[:top]
    ]

    def finite_mean(values):
        return (
            float(np.mean(values[np.isfinite(values)]))
            if np.isfinite(values).any()
            else float("nan")
        )

    return {
        "demos": len(dataset.demos),
        "steps": sum(demo.length - 1 for demo in dataset.demos),
        "moving_steps": int(np.sum(step_lengths(dataset) > MOVING_STEP)),
        **gradient_measures(model, dataset),
        "demos_ending_lower": int(
            sum(values[-1] < values[0] for values in values_along_demos(model, dataset))
        ),
        "late_from_step": late,
        "cosine_moving_early": finite_mean(moving[:, :late]),
        "cosine_moving_late": finite_mean(moving[:, late:]),
        "kept_features": len(scores),
        "selected_features": int(np.sum(scores > SELECTED_FRACTION * scores.max())),
        "features_95": features_carrying(model),
        "top_features": [{"name": name, "score": score} for name, score in ranked[:top]],
        "top_gradients_changing_sign": int(
            np.sum((np.nanmin(mean_gradient, axis=0) < 0) & (np.nanmax(mean_gradient, axis=0) > 0))
        ),
    }
