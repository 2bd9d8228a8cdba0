"""Situations files: a list of situations saved and loaded as YAML or JSON ({"situations": [...]},
each entry the fields of tric_sim.world.situation.Situation); every situation loaded is validated
and its scene checked against the robot (tric_sim.world.scene_check) when the file is read, before
any work, an error naming the file and the situation."""

import json
import pathlib

import yaml

from tric_sim.tools.output_files import write_text_atomic
from tric_sim.tools.untrusted import quoted, read_data_file
from tric_sim.world.scene_check import check_scene
from tric_sim.world.situation import Situation


def save_situations(path, situations) -> None:
    """Write situations to a .yaml/.yml or .json file as {"situations": [...]}."""
    path = pathlib.Path(path)
    data = {"situations": [s.to_dict() for s in situations]}
    write_text_atomic(
        path,
        json.dumps(data, indent=1) + "\n"
        if path.suffix == ".json"
        else yaml.safe_dump(data, sort_keys=False),
    )


def load_situations(path, robot=None) -> list:
    """Read a situations file (YAML or JSON, a list or {"situations": [...]}; size, depth and
    aliases limited as tric_sim.tools.untrusted.read_data_file says); each is validated and its
    scene checked against robot (check_scene; default: a new RobotModel)."""
    path = pathlib.Path(path)
    data = read_data_file(path, "situations file")
    if isinstance(data, dict):
        data = data.get("situations")
    if not isinstance(data, list) or not data:
        raise ValueError(f"{path} holds no situations (expected a list or {{situations: [...]}})")
    try:
        situations = [Situation.from_dict(entry) for entry in data]
        names = [s.name for s in situations]
        repeated = sorted({name for name in names if names.count(name) > 1})
        if repeated:
            raise ValueError(f"situation names must be unique ({quoted(repeated, 100)} repeat)")
        if robot is None:
            from tric_sim.world.robot_model import (
                RobotModel,  # Pinocchio's model: only when a file is read
            )

            robot = RobotModel()
        for situation in situations:
            check_scene(situation, robot)
    except ValueError as error:
        raise ValueError(f"situations file {quoted(str(path), 100)}: {error}") from None
    return situations
