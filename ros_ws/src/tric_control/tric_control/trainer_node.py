"""The trainer node ("trainer"): trains models from demonstration bags on request.

A thin ROS shell around tric_control.selection.select_model.select_from_bags (model kind "tric":
candidates trained side by side, rolled out from the demonstrations' starts, the best kept) and
tric_learning.training.dpl.train_dpl_from_bags (the DPL kinds), the jobs tric-train runs too.

Services:
- ~/train (tric_msgs/srv/Train): bags + hyper-parameters -> model file, final loss terms, kept and
  selected feature counts, times, and (TRIC) every candidate's seed and score and the seeds kept.
  Refused with success false and a message saying why (nothing is written) when the model kind is
  unknown, a hyper-parameter or selection setting is out of range (see training.TrainingConfig,
  dpl.DplConfig, selection.settings.SelectionConfig), a bag path does not exist or is not a
  finished TRIC recording of the same feature definition as the others, a bag's recorded outcome
  is a failure (unless include_failed), or the output path is not a writable .safetensors path.
  tolerant reads unfinished (.part) and damaged bags up to their damage; without it a folder's
  .part files are skipped. The answer's message names every bag skipped, read tolerantly or
  included despite its outcome. Request fields are taken as given (the .srv's defaults are the
  paper's), except hidden_units, candidates and members -1 and selection_score "" (the defaults)
  and an empty output_path (model.safetensors next to the first bag); so 0 is a value:
  hidden_units 0 is the linear model, noisy_samples 0 is refused. The DPL kinds ("dpl_joint",
  "dpl_finger": Sec. 5.3.2) take hidden_units, max_iterations, correlation_threshold and seed (the
  others are TRIC's and ignored; the L2 weight is DplConfig's); their answer has loss_total = the
  minimized least-squares objective, loss_n, loss_g, loss_w NaN, selected_features 0 and the
  training MSE in the message. The training runs in a worker thread while the executor keeps
  spinning; a request that comes meanwhile is answered at once with success false and a message
  starting "busy".

Topics:
- publishes ~/progress (tric_msgs/TrainingProgress) during a training: stage (TRIC: "loading",
  "candidates", "saving"; DPL: "loading", "optimizing", "saving"; then "done" or "failed"),
  overall fraction, the candidates finished (DPL: the optimizer's iteration), and loss terms.
  Every stage change is published, and within a stage at most one message per progress_period_s.

Parameters: progress_period_s (0.2): least wall seconds between two progress messages of a stage;
executor ("ray"): where the candidates train, "ray" (a local instance, or the cluster at address)
or "processes" (spawned here); address (""): a Ray cluster's; jobs (0: the CPUs): candidates at
once.
"""

import functools
import math
import os
import sys
import threading
import time

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node

from tric_control.evaluation.executors import (
    DEFAULT_EXECUTORS,
    EXECUTORS,
    ExecutorChoice,
    open_executor,
)
from tric_control.selection.select_model import select_from_bags
from tric_control.selection.settings import SelectionConfig
from tric_learning.model_file import KINDS
from tric_learning.training.dpl import DPL_KINDS, DplConfig, train_dpl_from_bags
from tric_learning.training.value import TrainingConfig
from tric_msgs.msg import TrainingProgress
from tric_msgs.srv import Train
from tric_sim.ros import messages
from tric_sim.ros.graph import run_node
from tric_sim.ros.parameters import NOT_NEGATIVE, Range, declare, declare_robot
from tric_sim.ros.topic_poller import run_in_thread

#: Overall progress spanned by each stage of a training: (start, end) fractions.
STAGE_SPANS = {
    "loading": (0.0, 0.05),
    "candidates": (0.05, 0.95),
    "optimizing": (0.05, 0.95),
    "saving": (0.95, 1.0),
}
STAGE_DETAILS = {
    "loading": "reading the bags",
    "candidates": "training candidates and rolling them out from the demonstrations' starts",
    "optimizing": "L-BFGS on DPL's loss (Eq. 2)",
    "saving": "writing the model file",
}
NO_LOSSES = {"total": math.nan, "n": math.nan, "g": math.nan, "w": math.nan}


def training_config(request: Train.Request):
    """The TrainingConfig (kind "tric") or DplConfig (a DPL kind) of a Train request; ValueError for
    an unknown model kind or a value out of range."""
    if request.model_kind not in KINDS:
        raise ValueError(f"unknown model_kind '{request.model_kind}' (known: {', '.join(KINDS)})")
    dpl_kind = request.model_kind in DPL_KINDS
    default_units = (DplConfig if dpl_kind else TrainingConfig).hidden_units
    hidden_units = default_units if request.hidden_units == -1 else request.hidden_units
    if dpl_kind:
        return DplConfig(
            hidden_units=hidden_units,
            max_iterations=request.max_iterations,
            correlation_threshold=request.correlation_threshold,
            seed=request.seed,
        ).validate()
    return TrainingConfig(
        hidden_units=hidden_units,
        noisy_samples=request.noisy_samples,
        sigma=request.sigma,
        alpha_n=request.alpha_n,
        alpha_g=request.alpha_g,
        alpha_w=request.alpha_w,
        max_iterations=request.max_iterations,
        correlation_threshold=request.correlation_threshold,
        seed=request.seed,
    ).validate()


def selection_config(request: Train.Request) -> SelectionConfig:
    """The SelectionConfig of a TRIC Train request (-1 and "": the defaults); ValueError for a
    value out of range."""
    defaults = SelectionConfig()
    return SelectionConfig(
        defaults.candidates if request.candidates == -1 else request.candidates,
        defaults.members if request.members == -1 else request.members,
        request.selection_score or defaults.score,
    ).validate()


class TrainerNode(Node):
    """Serves ~/train and publishes ~/progress (see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__("trainer", **kwargs)
        self.progress_period = declare(
            self,
            "progress_period_s",
            0.2,
            "least wall seconds between two progress messages of a stage",
            NOT_NEGATIVE,
        )
        kind = declare(
            self,
            "executor",
            DEFAULT_EXECUTORS["trainer"],
            "where the candidates train: Ray, or spawned processes here",
            EXECUTORS,
        )
        address = declare(self, "address", "", "a Ray cluster's address (empty: a local Ray)")
        if address and kind == "processes":
            raise ValueError("parameter address needs executor ray")
        self.executor_choice = ExecutorChoice(kind, address or None)
        self.jobs = declare(
            self, "jobs", 0, "candidates trained at once (0: the CPUs)", Range(0, 64)
        ) or (os.cpu_count() or 1)
        self.robot = declare_robot(self)
        self._candidates = 0  # of the running TRIC training
        self._busy = threading.Lock()
        self._last_report = (None, 0.0)  # (stage, monotonic time) of the last progress message
        self.progress_pub = self.create_publisher(TrainingProgress, "~/progress", 10)
        # reentrant: a second request is taken (and answered "busy") while the first one awaits its
        # worker
        self.create_service(
            Train, "~/train", self._on_train, callback_group=ReentrantCallbackGroup()
        )
        self.get_logger().info("ready to train on ~/train")

    async def _on_train(self, request: Train.Request, response: Train.Response) -> Train.Response:
        if not self._busy.acquire(blocking=False):
            response.success = False
            response.message = "busy: another training is running; call again when it has finished"
            return response
        try:
            return await self._train(request, response)
        finally:
            self._busy.release()

    async def _train(self, request: Train.Request, response: Train.Response) -> Train.Response:
        start = time.monotonic()
        self._last_report = (None, 0.0)
        notes: list = []
        notice = functools.partial(self._notice, notes)
        try:
            config = training_config(request)
            if request.model_kind == "tric":
                selection = selection_config(request)
                run = await run_in_thread(self, self._select, request, config, selection, notice)
            else:
                run = await run_in_thread(
                    self,
                    functools.partial(
                        train_dpl_from_bags,
                        kind=request.model_kind,
                        include_failed=request.include_failed,
                        tolerant=request.tolerant,
                        notice=notice,
                    ),
                    list(request.bag_paths),
                    request.output_path,
                    config,
                    self.robot,
                    functools.partial(self._report, config.max_iterations),
                )
        except (ValueError, OSError, ConnectionError) as error:
            return self._fail(response, str(error))
        except Exception as error:  # a bug: still an answer, not a traceback
            self.get_logger().error(f"training failed: {error!r}")
            return self._fail(response, f"internal error: {type(error).__name__}: {error}")
        summary = (
            f"trained on {len(run.dataset.demos)} demonstrations in "
            f"{time.monotonic() - start:.1f} s"
        )
        response.success = True
        response.model_path = str(run.path)
        if request.model_kind == "tric":
            info, provenance = run.choice.model.info, run.choice.provenance
            losses = dict(NO_LOSSES, **info["losses"])
            response.input_features = len(info["kept_features"])
            response.selected_features = info["selected_features"]
            response.sampling_time_s = info["sampling_time_s"]
            response.optimization_time_s = info["optimization_time_s"]
            response.train_time_s = run.wall_s
            rows = provenance["candidates"]
            response.candidate_seeds = [row["seed"] for row in rows]
            response.candidate_scores = [
                math.nan if row["score"] is None else float(row["score"]) for row in rows
            ]
            response.chosen_seeds = list(provenance["chosen"])
            chosen = ", ".join(str(seed) for seed in provenance["chosen"])
            response.message = (
                f"{summary}: chose seed {chosen} of {len(rows)} candidates by the score "
                f"'{provenance['config']['score']}'; loss {losses['total']:.4f} (L_n "
                f"{losses['n']:.4f}, L_g {losses['g']:.4f}, |w|_1 {losses['w']:.2f}), "
                f"{response.input_features} features kept, {response.selected_features} "
                f"selected; wrote {run.path}"
            )
            done = {"iteration": len(rows), "max_iterations": len(rows)}
        else:
            result, losses = run.result, dict(NO_LOSSES, **run.result.losses)
            response.optimization_time_s = result.optimization_time_s
            response.train_time_s = result.train_time_s
            response.input_features = len(result.policy.scaling.kept)
            response.message = (
                f"{request.model_kind} {summary}: training MSE {losses['mse']:.3g} per output "
                f"(mean |error| {losses['mean_abs_error']:.3g}), {response.input_features} "
                f"features kept; wrote {run.path}"
            )
            done = {"iteration": result.iterations, "max_iterations": config.max_iterations}
        response.loss_total, response.loss_n, response.loss_g, response.loss_w = (
            losses["total"],
            losses["n"],
            losses["g"],
            losses["w"],
        )
        if notes:
            response.message += f" ({'; '.join(notes)})"
        self._publish("done", 1.0, losses, message=response.message, **done)
        self.get_logger().info(response.message)
        return response

    def _select(self, request: Train.Request, config, selection: SelectionConfig, notice):
        """The TRIC job (in the worker thread): load, choose among candidates, save."""
        self._candidates = selection.candidates
        with open_executor(self.executor_choice, num_cpus=self.jobs) as executor:
            return select_from_bags(
                list(request.bag_paths),
                request.output_path,
                config,
                selection,
                self.robot,
                executor,
                self.jobs,
                self._report_candidates,
                include_failed=request.include_failed,
                tolerant=request.tolerant,
                notice=notice,
            )

    def _report_candidates(self, stage: str, fraction: float, what) -> None:
        """select_from_bags' progress callback (in the worker thread): each stage change and each
        finished candidate (with its losses) at once, the rest at most every progress_period_s."""
        total = self._candidates
        if stage == "candidates" and what is not None:
            self._last_report = (None, 0.0)
        losses = getattr(what, "record", {}).get("losses") if stage == "candidates" else what
        done = round(fraction * total) if stage == "candidates" else 0
        self._report(total, stage, fraction, losses, iteration=done)

    def _notice(self, notes: list, text: str) -> None:
        """What the dataset loader names (skipped, tolerantly read or included bags): logged, and
        kept for the answer."""
        notes.append(text)
        self.get_logger().warning(text)

    def _fail(self, response: Train.Response, message: str) -> Train.Response:
        response.success, response.message = False, message
        self._publish("failed", 0.0, None, message=message)
        self.get_logger().warning(f"no model trained: {message}")
        return response

    def _report(
        self, max_iterations: int, stage: str, fraction: float, losses, iteration=None
    ) -> None:
        """train_dpl_from_bags' progress callback (in the worker thread): publish stage changes at
        once, the rest at most every progress_period_s."""
        last_stage, last_time = self._last_report
        now = time.monotonic()
        if stage == last_stage and now - last_time < self.progress_period:
            return
        low, high = STAGE_SPANS[stage]
        if iteration is None:
            iteration = int(losses["iteration"]) if losses and "iteration" in losses else 0
        self._publish(
            stage,
            low + (high - low) * fraction,
            losses,
            message=STAGE_DETAILS[stage],
            iteration=iteration,
            max_iterations=max_iterations,
        )

    def _publish(
        self,
        stage: str,
        fraction: float,
        losses,
        message: str = "",
        iteration: int = 0,
        max_iterations: int = 0,
    ) -> None:
        losses = dict(NO_LOSSES, **(losses or {}))
        msg = TrainingProgress(
            stage=stage,
            iteration=iteration,
            max_iterations=max_iterations,
            fraction=float(fraction),
            loss_total=losses["total"],
            loss_n=losses["n"],
            loss_g=losses["g"],
            loss_w=losses["w"],
            message=message,
        )
        msg.header.stamp = messages.time_msg(time.time_ns())
        self._last_report = (stage, time.monotonic())
        self.progress_pub.publish(msg)


def main(args=None):
    return run_node(TrainerNode, "trainer", args)


if __name__ == "__main__":
    sys.exit(main())
