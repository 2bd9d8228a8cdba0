"""Render one frame of a recorded episode as Foxglove's layout shows it (docs/foxglove_layout.json):
the 3D scene drawn from the bag's own /scene_markers and /tf (with /tf_static), beside f and the
step over the episode and the top features' gradients at that instant from /controller/status.

    python scripts/render_bag_frame.py BAG --out PNG [--at FRACTION]

BAG: a bag of `tric-eval --record` (or of the recorder); FRACTION in [0, 1]: the instant, as a share
of the episode (default 0.5). Made the picture docs/images/foxglove_frame.png.
"""

import argparse
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from tric_learning import bags  # noqa: E402
from tric_sim.viz import scene_view  # noqa: E402
from tric_sim.world import scene  # noqa: E402

SHAPES = {1: "box", 2: "sphere", 3: "cylinder"}  # visualization_msgs/Marker CUBE, SPHERE, CYLINDER
SEGMENTS = 24


def transforms(msg) -> scene_view.Transforms:
    """A tf2_msgs/TFMessage as read from a bag."""
    parts = [
        (
            t.header.frame_id,
            t.child_frame_id,
            [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z],
            [
                t.transform.rotation.x,
                t.transform.rotation.y,
                t.transform.rotation.z,
                t.transform.rotation.w,
            ],
        )
        for t in msg.transforms
    ]
    parents, children, positions, orientations = zip(*parts)
    return scene_view.Transforms(parents, children, np.array(positions), np.array(orientations))


def unit_faces(shape: str) -> list:
    """Polygons (k, 3) of a unit primitive: a cube of side 1, a sphere and a cylinder of diameter 1
    (height 1, axis z), centred at the origin."""
    if shape == "box":
        corners = np.array(
            [[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
        )
        faces = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
        return [corners[list(face)] for face in faces]
    angles = np.linspace(0.0, 2 * np.pi, SEGMENTS + 1)
    if shape == "cylinder":
        ring = 0.5 * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        sides = [
            np.array([[*ring[k], -0.5], [*ring[k + 1], -0.5], [*ring[k + 1], 0.5], [*ring[k], 0.5]])
            for k in range(SEGMENTS)
        ]
        caps = [np.column_stack([ring, np.full(len(ring), z)]) for z in (-0.5, 0.5)]
        return sides + caps
    polar = np.linspace(0.0, np.pi, SEGMENTS // 2 + 1)
    point = lambda a, p: 0.5 * np.array([np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)])  # noqa: E731
    return [
        np.array(
            [
                point(angles[i], polar[j]),
                point(angles[i + 1], polar[j]),
                point(angles[i + 1], polar[j + 1]),
                point(angles[i], polar[j + 1]),
            ]
        )
        for i in range(SEGMENTS)
        for j in range(SEGMENTS // 2)
    ]


def draw_scene(axes, markers, placements) -> None:
    """Every marker as polygons in the world frame, one collection (depth-sorted together)."""
    polygons, colors = [], []
    for marker in markers:
        if marker.type not in SHAPES or marker.header.frame_id not in placements:
            continue
        position, orientation = marker.pose.position, marker.pose.orientation
        pose = placements[marker.header.frame_id] * scene.se3(
            [position.x, position.y, position.z],
            [orientation.x, orientation.y, orientation.z, orientation.w],
        )
        scale = np.array([marker.scale.x, marker.scale.y, marker.scale.z])
        color = (marker.color.r, marker.color.g, marker.color.b, min(marker.color.a, 0.9))
        for face in unit_faces(SHAPES[marker.type]):
            polygons.append((face * scale) @ pose.rotation.T + pose.translation)
            colors.append(color)
    axes.add_collection3d(
        Poly3DCollection(polygons, facecolors=colors, edgecolors=(0, 0, 0, 0.08), linewidths=0.3)
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("bag", type=pathlib.Path)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    parser.add_argument(
        "--at", type=float, default=0.5, help="the instant, as a share of the episode"
    )
    args = parser.parse_args(argv)
    if not 0.0 <= args.at <= 1.0:
        parser.error("--at must be in [0, 1]")
    read = {}
    try:
        for message in bags.read_bag(
            args.bag, topics=["/tf", "/tf_static", "/scene_markers", "/controller/status"]
        ):
            read.setdefault(message.topic, []).append(message)
    except ValueError as error:
        print(f"render_bag_frame: {error}", file=sys.stderr)
        return 2
    missing = [
        t for t in ("/tf", "/tf_static", "/scene_markers", "/controller/status") if t not in read
    ]
    if missing:
        print(f"render_bag_frame: {args.bag} has no {', '.join(missing)}", file=sys.stderr)
        return 2
    statuses = [m.message for m in read["/controller/status"]]
    status = statuses[min(int(args.at * len(statuses)), len(statuses) - 1)]
    stamp = status.header.stamp.sec * 10**9 + status.header.stamp.nanosec
    tf = min(read["/tf"], key=lambda m: abs(m.stamp_ns - stamp))
    placements = scene_view.frame_placements(
        transforms(read["/tf_static"][0].message), transforms(tf.message)
    )

    figure = Figure(figsize=(12.0, 5.6), layout="constrained")
    grid = figure.add_gridspec(2, 2, width_ratios=(1.35, 1.0))
    axes = figure.add_subplot(grid[:, 0], projection="3d")
    draw_scene(axes, read["/scene_markers"][0].message.markers, placements)
    axes.set(
        xlim=(-0.05, 0.75),
        ylim=(-0.45, 0.35),
        zlim=(0.0, 0.8),
        xlabel="x (m)",
        ylabel="y (m)",
        zlabel="z (m)",
    )
    axes.set_box_aspect((1, 1, 1))
    axes.view_init(elev=20, azim=-120)
    axes.set_title(f"/scene_markers placed by /tf at step {status.step}")
    value_axes = figure.add_subplot(grid[0, 1])
    steps = [s.step for s in statuses]
    value_axes.plot(steps, [s.value for s in statuses], color="tab:blue", label="f")
    value_axes.axvline(status.step, color="grey", linewidth=1)
    value_axes.set(
        xlabel="control tick",
        ylabel="f (learned value)",
        title="/controller/status: f and the step",
    )
    step_axes = value_axes.twinx()
    step_axes.plot(
        steps, [s.step_norm for s in statuses], color="tab:orange", linewidth=0.8, label="|dq|"
    )
    step_axes.set_ylabel("|dq| (rad)")
    value_axes.legend(handles=value_axes.lines[:1] + step_axes.lines, loc="upper right")
    feature_axes = figure.add_subplot(grid[1, 1])
    names = list(status.feature_names)
    feature_axes.barh(
        np.arange(len(names)),
        status.feature_gradients,
        color=["tab:red" if g > 0 else "tab:green" for g in status.feature_gradients],
    )
    feature_axes.set_yticks(
        np.arange(len(names)),
        [f"{n}  (u = {u:.2f})" for n, u in zip(names, status.feature_values)],
        fontsize=7,
    )
    feature_axes.invert_yaxis()
    feature_axes.set(xlabel="df/du", title="top features by score: gradient now")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=100)
    print(f"wrote {args.out} (step {status.step}, f = {status.value:.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
