"""What the controller node (tric_control.controller_node) holds: the loaded model, the current
scene and the running ~/execute episode, with the episode's result and events as its messages
report them."""

import math
import time

from rclpy.task import Future

from tric_control.episode_runner import EpisodeRunner
from tric_control.top_features import TopFeatures
from tric_learning.model_file import ModelFile
from tric_msgs.msg import EpisodeEvent
from tric_msgs.msg import Situation as SituationMsg
from tric_sim.ros import messages
from tric_sim.world.proximity import Proximity

#: Wall seconds between checks of cancel requests and the state timeout (lockstep waits, realtime
#: watchdog).
POLL_S = 0.05


class Loaded:
    """A loaded model: its file, path, controller objective and the top features its status
    shows."""

    def __init__(self, path: str, model_file: ModelFile, objective):
        self.path, self.file, self.objective = path, model_file, objective
        self.top_features = TopFeatures(objective)
        self.kind = model_file.kind
        self.objects = tuple(
            source.partition("/")[2]
            for source in model_file.definition.landmark_sources
            if source.startswith("object/")
        )


class Scene:
    """The current situation and the collision queries for it."""

    def __init__(self, situation, msg: SituationMsg, proximity: Proximity):
        self.situation, self.msg, self.proximity = situation, msg, proximity


class Episode:
    """One run of ~/execute: its goal, model, scene and runner (tric_control.episode_runner)."""

    def __init__(
        self, goal_handle, episode_id: str, model: Loaded, scene: Scene, runner: EpisodeRunner
    ):
        self.goal_handle, self.episode_id, self.model, self.scene = (
            goal_handle,
            episode_id,
            model,
            scene,
        )
        self.runner = runner
        self.start_ns = None  # stamp of the first answered state (START), None before it
        self.last_ns = None  # stamp of the last answered state
        self.wall_start = time.monotonic()
        self.done = Future()  # realtime: (outcome, message) when the episode is over

    @property
    def steps(self) -> int:
        return self.runner.stats.steps

    def finish(self, outcome: str, message: str = "") -> None:
        if not self.done.done():
            self.done.set_result((outcome, message))

    def fill(self, result) -> None:
        stats = self.runner.stats
        result.steps = stats.steps
        result.initial_value, result.final_value = stats.initial_value, stats.final_value
        result.min_distance = stats.min_distance if stats.steps else math.nan
        result.min_joint_limit_margin = stats.min_joint_margin if stats.steps else math.nan
        result.wall_time_s = time.monotonic() - self.wall_start
        result.mean_tick_ms, result.max_tick_ms = stats.mean_tick_ms, stats.max_tick_ms

    def event(self, kind):
        """The EpisodeEvent of kind for this episode; None for END and ABORT of an episode that
        never started."""
        if kind != EpisodeEvent.START and self.start_ns is None:
            return None
        msg = EpisodeEvent(event=kind, episode_id=self.episode_id, source=self.model.kind)
        msg.header.stamp = messages.time_msg(
            self.start_ns if kind == EpisodeEvent.START else self.last_ns
        )
        if kind == EpisodeEvent.START:
            msg.situation = self.scene.msg
        return msg
