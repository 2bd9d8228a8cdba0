"""A robot as data: the profile file that names a robot's description (URDF, SRDF), its arm's and
hand's joints, its landmark frames, its start, its hand's pre-shapes and grip, and its contact rules
(docs/robots.md). The simulator, the teachers, the features, the judge and the controller read a
robot only through its profile; the paper's robot is the profile `tric_arm_hand`.

A profile is checked against its URDF when it is loaded: every joint it names must be a moving,
non-mimic joint of the URDF (arm and hand together: all of them), every frame a link of it; a
mistake is refused with the name and the file in the message. Units: rad, m, s.
"""

import hashlib
import math
import pathlib
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Any

import yaml

from tric_sim.world.profile_entries import GraspTeacherSettings, Workspace, grasp_teacher, workspace

#: Where the profiles shipped with tric_sim live (next to their URDFs), and the default robot.
PROFILE_DIR = pathlib.Path(__file__).resolve().parents[1] / "description"
DEFAULT_ROBOT = "tric_arm_hand"

_KEYS = {
    "name": str,
    "urdf": str,
    "srdf": str,
    "arm_joints": list,
    "hand_joints": list,
    "home": dict,
    "base": str,
    "palm": str,
    "fingers": list,
    "distal_radius": float,
    "lid_fingertips": list,
    "preshapes": dict,
    "grip": dict,
    "hand_root": str,
    "mounted_links": list,
    "clearance": dict,
    "grasp_teacher": dict,
}
#: The optional entries: `workspace` (the robot's data sets: see Workspace) and `grasp_centre`
#: (a frame where the hand holds what it grasps, between a parallel gripper's pads: a landmark of
#: the grasp features when given).
_OPTIONAL_KEYS = ("derive", "workspace", "grasp_centre")
_FINGER_KEYS = ("joints", "links", "tip", "middle", "base")
#: A finger's entry may also give `closing`: per joint, +1 if the finger closes as the joint's value
#: rises (the default), -1 if it closes as it falls (a gripper finger that slides inwards).
_FINGER_OPTIONS = ("closing",)
#: The object kinds a profile gives pre-shapes for, and the teachers that use clearance points.
PRESHAPE_KINDS = ("sphere", "cylinder", "box")
CLEARANCE_TEACHERS = ("grasp", "box")


@dataclass(frozen=True)
class Finger:
    """One finger: its flexion joints (base to tip; none when a mimic joint moves it), its links
    (proximal to distal; one for a gripper's finger), its frames."""

    joints: tuple
    links: tuple
    tip: str
    middle: str
    base: str
    closing: tuple  # per joint, +1.0 (closes as it rises) or -1.0 (as it falls)


@dataclass(frozen=True)
class RobotProfile:
    """A checked robot profile (see the module docstring and tric_arm_hand.yaml for each field).

    home: joint -> rad; preshapes: kind -> {joint: rad}; grip_squeeze (rad) and grip_duration_s
    (s); hand_links: hand_root and every link below it; mounted_links: the links mounted on the
    table with the base, never checked against the scene; clearance: teacher -> ((frame, offset
    along the frame's z in m, radius in m), ...); grasp_teacher: GraspTeacherSettings; workspace:
    Workspace (the paper's unless the profile gives one); digest: SHA-256 of the profile file and
    its URDF; grasp_centre: the frame where the hand holds what it grasps, "" when the profile names
    none.
    """

    name: str
    path: pathlib.Path
    urdf_path: pathlib.Path
    srdf_path: pathlib.Path
    arm_joints: tuple
    hand_joints: tuple
    home: dict
    base: str
    palm: str
    fingers: tuple
    distal_radius: float
    lid_fingertips: tuple
    preshapes: dict
    grip_squeeze: float
    grip_duration_s: float
    hand_root: str
    hand_links: frozenset
    mounted_links: tuple
    clearance: dict
    grasp_teacher: GraspTeacherSettings
    workspace: Workspace
    digest: str
    grasp_centre: str = ""

    @property
    def identity(self) -> str:
        """'<name>:<digest>': what bags and model files record of the profile they were made
        with."""
        return f"{self.name}:{self.digest}"

    def change_since(self, recorded: str, what: str) -> str:
        """A note when what (a bag, a model file) recorded this robot's profile with another
        digest: the profile or its URDF changed since it was made; "" when recorded is this
        identity, empty (made before files recorded it) or another robot's (whose feature
        definition refuses it, naming both)."""
        name, _, digest = recorded.partition(":")
        if name != self.name or not digest or digest == self.digest:
            return ""
        return (
            f"{what} was made with another version of the robot profile '{self.name}' (digest "
            f"{digest[:12]}, now {self.digest[:12]}): its profile or URDF changed since"
        )

    @property
    def spec(self) -> str:
        """What names this profile to load_profile in another process: its name when it is the
        shipped profile of that name, else its file's path."""
        shipped = PROFILE_DIR / f"{self.name}.yaml"
        return self.name if shipped.resolve() == self.path.resolve() else str(self.path)

    @property
    def grasp_centres(self) -> tuple:
        """The grasp centre's frame as a tuple: one frame when the profile names it, else none."""
        return (self.grasp_centre,) if self.grasp_centre else ()

    @property
    def fingertips(self) -> tuple:
        return tuple(finger.tip for finger in self.fingers)

    @property
    def finger_middles(self) -> tuple:
        return tuple(finger.middle for finger in self.fingers)

    @property
    def distal_links(self) -> tuple:
        return tuple(finger.links[-1] for finger in self.fingers)

    @property
    def closing_signs(self) -> dict:
        """flexion joint -> +1.0 if its finger closes as the joint rises, -1.0 if as it falls."""
        return {j: sign for f in self.fingers for j, sign in zip(f.joints, f.closing)}

    @property
    def flexion_joints(self) -> tuple:
        """The hand's joints that flex its fingers, in the order of hand_joints."""
        flexing = {joint for finger in self.fingers for joint in finger.joints}
        return tuple(joint for joint in self.hand_joints if joint in flexing)


def profile_path(robot: str | pathlib.Path) -> pathlib.Path:
    """The profile file of a robot: a path to a .yaml file, or the name of a profile shipped with
    tric_sim (PROFILE_DIR/<name>.yaml)."""
    path = pathlib.Path(robot)
    if path.suffix in (".yaml", ".yml"):
        return path
    shipped = PROFILE_DIR / f"{robot}.yaml"
    if not shipped.is_file():
        known = sorted(p.stem for p in PROFILE_DIR.glob("*.yaml"))
        raise ValueError(
            f"no robot profile '{robot}' (shipped: {', '.join(known)}; or a .yaml path)"
        )
    return shipped


def load_profile(robot: str | pathlib.Path = DEFAULT_ROBOT) -> RobotProfile:
    """The checked profile of a robot (a name or a path: profile_path); a mistake raises ValueError
    naming the file and the entry."""
    path = profile_path(robot)
    try:
        text = path.read_text()
    except OSError as error:
        raise ValueError(f"robot profile {path}: cannot be read ({error.strerror})") from None
    try:
        return _parse(path, yaml.safe_load(text), text)
    except (ValueError, yaml.YAMLError) as error:
        raise ValueError(f"robot profile {path}: {error}") from None


def _parse(path: pathlib.Path, data: Any, text: str) -> RobotProfile:
    if not isinstance(data, dict):
        raise ValueError("expected a mapping of the profile's entries")
    missing = [key for key in _KEYS if key not in data]
    unknown = sorted(set(data) - set(_KEYS) - set(_OPTIONAL_KEYS))
    if missing or unknown:
        raise ValueError(f"missing entries {missing}, unknown entries {unknown}")
    for key, kind in _KEYS.items():
        value = data[key]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = data[key] = float(value)
        if not isinstance(value, kind):
            raise ValueError(f"'{key}' must be a {kind.__name__}, not {value!r}")
    urdf_path, srdf_path = path.parent / data["urdf"], path.parent / data["srdf"]
    if not urdf_path.is_file():
        how = " (python -m tric_sim.world.derived_urdf writes it)" if "derive" in data else ""
        raise ValueError(f"its URDF {urdf_path} does not exist{how}")
    joints, children = _urdf_joints_and_links(urdf_path)
    links = set(children)
    arm, hand = tuple(data["arm_joints"]), tuple(data["hand_joints"])
    actuated = arm + hand
    for joint in actuated:
        if joint not in joints:
            raise ValueError(
                f"joint '{joint}' is not a moving, non-mimic joint of {urdf_path.name}"
            )
    left_out = sorted(set(joints) - set(actuated))
    if left_out or len(set(actuated)) != len(actuated):
        raise ValueError(
            f"arm_joints and hand_joints must name each moving joint of {urdf_path.name} once "
            f"(left out: {left_out})"
        )
    home = _angles("home", data["home"], actuated)
    if set(home) != set(actuated):
        raise ValueError(
            f"'home' must give every joint (missing: {sorted(set(actuated) - set(home))})"
        )
    fingers = tuple(_finger(k, entry, hand, links) for k, entry in enumerate(data["fingers"]))
    if not fingers:
        raise ValueError("'fingers' lists no finger")
    for key in ("base", "palm"):
        _check_frame(key, data[key], links)
    if "grasp_centre" in data:
        _check_frame("grasp_centre", data["grasp_centre"], links)
    lid_fingertips = tuple(data["lid_fingertips"])
    for frame in lid_fingertips:
        _check_frame("lid_fingertips", frame, links)
    preshapes = data["preshapes"]
    if sorted(preshapes) != sorted(PRESHAPE_KINDS):
        raise ValueError(f"'preshapes' must give the kinds {list(PRESHAPE_KINDS)}")
    preshapes = {kind: _angles(f"preshapes.{kind}", preshapes[kind], hand) for kind in preshapes}
    grip = data["grip"]
    if sorted(grip) != ["duration_s", "squeeze"] or not all(
        isinstance(v, (int, float)) and v >= 0 for v in grip.values()
    ):
        raise ValueError(f"'grip' must be {{squeeze: rad >= 0, duration_s: s >= 0}}, not {grip}")
    _check_frame("hand_root", data["hand_root"], links)
    for link in data["mounted_links"]:
        _check_frame("mounted_links", link, links)
    hand_links, below = set(), [data["hand_root"]]
    while below:
        link = below.pop()
        hand_links.add(link)
        below += children[link]
    clearance = data["clearance"]
    if sorted(clearance) != sorted(CLEARANCE_TEACHERS):
        raise ValueError(f"'clearance' must give the teachers {list(CLEARANCE_TEACHERS)}")
    digest = hashlib.sha256(text.encode() + urdf_path.read_bytes()).hexdigest()
    return RobotProfile(
        name=data["name"],
        path=path,
        urdf_path=urdf_path,
        srdf_path=srdf_path,
        arm_joints=arm,
        hand_joints=hand,
        home=home,
        base=data["base"],
        palm=data["palm"],
        fingers=fingers,
        distal_radius=data["distal_radius"],
        lid_fingertips=lid_fingertips,
        preshapes=preshapes,
        grip_squeeze=float(grip["squeeze"]),
        grip_duration_s=float(grip["duration_s"]),
        hand_root=data["hand_root"],
        hand_links=frozenset(hand_links),
        mounted_links=tuple(data["mounted_links"]),
        clearance={
            teacher: tuple(_clearance_point(teacher, p, links) for p in clearance[teacher])
            for teacher in CLEARANCE_TEACHERS
        },
        grasp_teacher=grasp_teacher(data["grasp_teacher"]),
        workspace=workspace(data.get("workspace", {})),
        digest=digest,
        grasp_centre=data.get("grasp_centre", ""),
    )


def _urdf_joints_and_links(urdf_path: pathlib.Path) -> tuple:
    """The URDF's moving, non-mimic joints, and its links: name -> the links its joints carry."""
    try:
        root = ET.parse(urdf_path).getroot()
    except ET.ParseError as error:
        raise ValueError(f"its URDF {urdf_path} is not XML ({error})") from None
    joints = [
        joint.get("name")
        for joint in root.iter("joint")
        if joint.get("type") != "fixed" and joint.find("mimic") is None
    ]
    children: dict = {link.get("name"): [] for link in root.iter("link")}
    for joint in root.iter("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is not None and child is not None and parent.get("link") in children:
            children[parent.get("link")].append(child.get("link"))
    return joints, children


def _check_frame(key: str, frame: Any, links: set) -> None:
    if frame not in links:
        raise ValueError(f"{key}: frame '{frame}' is not a link of the URDF")


def _angles(key: str, values: Any, allowed: tuple) -> dict:
    """A {joint: rad} mapping over joints of allowed, each angle a finite number."""
    if not isinstance(values, dict):
        raise ValueError(f"'{key}' must map joints to angles, not {values!r}")
    for joint, angle in values.items():
        if joint not in allowed:
            raise ValueError(f"{key}: joint '{joint}' is not one of {list(allowed)}")
        if (
            isinstance(angle, bool)
            or not isinstance(angle, (int, float))
            or not math.isfinite(angle)
        ):
            raise ValueError(f"{key}: '{joint}' must be a finite angle in rad, not {angle!r}")
    return {joint: float(angle) for joint, angle in values.items()}


def _finger(k: int, entry: Any, hand: tuple, links: set) -> Finger:
    if (
        not isinstance(entry, dict)
        or not set(_FINGER_KEYS) <= set(entry)
        or not set(entry) <= {*_FINGER_KEYS, *_FINGER_OPTIONS}
    ):
        raise ValueError(
            f"finger {k + 1} must give {list(_FINGER_KEYS)}, and may give {list(_FINGER_OPTIONS)}"
        )
    closing = entry.get("closing", [1] * len(entry["joints"]))
    if (
        not isinstance(closing, list)
        or len(closing) != len(entry["joints"])
        or any(sign not in (1, -1) or isinstance(sign, bool) for sign in closing)
    ):
        raise ValueError(f"finger {k + 1}: closing must give +1 or -1 for each of its joints")
    for joint in entry["joints"]:
        if joint not in hand:
            raise ValueError(f"finger {k + 1}: joint '{joint}' is not one of hand_joints")
    for key in ("links", "tip", "middle", "base"):
        frames = entry[key] if key == "links" else [entry[key]]
        for frame in frames:
            _check_frame(f"finger {k + 1} {key}", frame, links)
    if not entry["links"]:
        raise ValueError(f"finger {k + 1} names no link")
    return Finger(
        tuple(entry["joints"]),
        tuple(entry["links"]),
        entry["tip"],
        entry["middle"],
        entry["base"],
        tuple(float(sign) for sign in closing),
    )


def _clearance_point(teacher: str, point: Any, links: set) -> tuple:
    """(frame, offset m, radius m) of a teacher's clearance list."""
    if (
        not isinstance(point, list)
        or len(point) != 3
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in point[1:])
    ):
        raise ValueError(
            f"clearance.{teacher}: expected [frame, offset m, radius m], not {point!r}"
        )
    _check_frame(f"clearance.{teacher}", point[0], links)
    return (point[0], float(point[1]), float(point[2]))
