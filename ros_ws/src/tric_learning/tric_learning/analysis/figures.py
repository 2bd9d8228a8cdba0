"""The paper's analyses of a trained TRIC model, as PNGs (Fig. 12, 13, 14a, 14b, 15, 16 and 17a-c),
and their key numbers (tric-analyze, tric-experiments' analysis). In the folder DIR:

Fig. 13 (DIR/value_along_demos.png): the value f(y_t) along every demonstration in BAGS (bags or
folders of bags, the training ones or others of the same feature definition) over normalized time
t / (T - 1); a model that explains its demonstrations decreases along each of them.
Fig. 14a (DIR/gradient_cosines.png): L_g's cosine between grad_q (f o phi)(q_t) = (df/dy)(dphi/dq),
from the recorded Jacobians, and the demonstrated step q_{t+1} - q_t, for every demonstration and
step (a heatmap; -1: f falls fastest along the step), and its mean over the demonstrations by step.
Fig. 16 (DIR/feature_scores.png): the kept features' scores s(y) = |W1^T| |W2| + |W3| (Sec. 5.5.1),
sorted, with the selection threshold, and the top N (20) by name.
Fig. 17a (DIR/mean_gradients.png): the mean over the demonstrations of df/dy at each step (on the
features rescaled to [0, 1], the paper's y) for the top N features by score.
Fig. 12 (DIR/box_task_spaces.png, box bags only): the first FIG12_DEMOS box openings in three task
spaces, in 3D, start green, end red: the joints' first three principal components (over those
demonstrations' samples), the box in fingertip 2's frame (the recorded p[fingertip_2->box]) and
fingertip 2 in the box's frame (p[box->fingertip_2]).
Fig. 14b (DIR/collision_prior.png): the controller's collision prior along the demonstrations: per
step, the smallest signed distance (m) between the hand (palm and finger links) and the body it may
touch (the grasp target, or the box's lid), and how many such hand-body pairs are within the
controller's influence distance CONTROLLER_INFLUENCE; each demonstration light, their mean bold.
Distances from the recorded q and object poses with coal on the robot's collision model.
Fig. 15 (DIR/kernel_pca.png): kernel PCA (Gaussian kernel, bandwidth by the median heuristic: the
median distance between the samples) of every demonstration sample's kept features rescaled to
[0, 1], and of the hidden layer z = sigmoid(W1 u) (Sec. 5.4.2), in 2-D, coloured by f, the last
samples ringed; a linear model (K = 0) has no z, and only the first panel is drawn.
Fig. 17b/c (DIR/feature_over_time.png): the raw value (m) and df/du of the feature ranked
--feature-rank (8, as the paper's) by score, over the steps: each demonstration light, the mean
bold.

Each figure is drawn by its module: value_figures (13, 14a), feature_figures (16, 17a, 17b/c),
space_figures (12, 15) and collision_figure (14b); write_figures() draws them all.
"""

import pathlib

from tric_learning.analysis.collision_figure import plot_collision_prior
from tric_learning.analysis.feature_figures import (
    plot_feature_over_time,
    plot_gradients,
    plot_scores,
)
from tric_learning.analysis.measures import (
    DEFAULT_FEATURE_RANK,
    cosines_along_demos,
    feature_over_time,
    gradients_along_demos,
    hand_body_distances,
    hand_geometries,
    kernel_pca_inputs,
    mean_over_demos,
    moving_only,
    ranked_features,
    values_along_demos,
)
from tric_learning.analysis.space_figures import plot_kernel_pca, plot_task_spaces
from tric_learning.analysis.value_figures import plot_cosines, plot_values
from tric_learning.training.dataset import Dataset
from tric_learning.value_function import ValueFunction
from tric_sim.world.robot_model import RobotModel

VALUE_FIGURE = "value_along_demos.png"


COSINES_FIGURE = "gradient_cosines.png"


SCORES_FIGURE = "feature_scores.png"


GRADIENTS_FIGURE = "mean_gradients.png"


TASK_SPACES_FIGURE = "box_task_spaces.png"


COLLISION_FIGURE = "collision_prior.png"


KERNEL_PCA_FIGURE = "kernel_pca.png"


FEATURE_FIGURE = "feature_over_time.png"


def write_figures(
    model: ValueFunction,
    dataset: Dataset,
    out: pathlib.Path,
    top: int,
    feature_rank: int = DEFAULT_FEATURE_RANK,
    robot: RobotModel | None = None,
) -> list:
    """The figures of model on dataset in out (created): Fig. 13, 14a, 16, 17a, 15 and 17b/c, then
    Fig. 12 for box-opening demos and Fig. 14b when a robot model is given; their paths."""
    out.mkdir(parents=True, exist_ok=True)
    names = dataset.definition.feature_names
    cosines = cosines_along_demos(model, dataset)
    gradients = gradients_along_demos(model, dataset)
    paths = [
        plot_values(
            values_along_demos(model, dataset),
            [demo.name for demo in dataset.demos],
            out / VALUE_FIGURE,
        ),
        plot_cosines(cosines, moving_only(cosines, dataset), out / COSINES_FIGURE),
        plot_scores(ranked_features(model, names), out / SCORES_FIGURE, top),
        plot_gradients(mean_over_demos(gradients), model, names, out / GRADIENTS_FIGURE, top),
        plot_kernel_pca(kernel_pca_inputs(model, dataset), out / KERNEL_PCA_FIGURE),
        plot_feature_over_time(
            *feature_over_time(model, dataset, feature_rank, gradients),
            feature_rank,
            out / FEATURE_FIGURE,
        ),
    ]
    if dataset.definition.task == "open_box":
        paths.append(plot_task_spaces(dataset, out / TASK_SPACES_FIGURE))
    if robot is not None:
        distances, counts, role = hand_body_distances(robot, dataset)
        paths.append(
            plot_collision_prior(
                distances, counts, role, len(hand_geometries(robot)), out / COLLISION_FIGURE
            )
        )
    return paths
