"""The experiments' runner: chooses (or re-uses) their models under DIR/models as a training
chooses them (TRIC: the best of the default selection's candidates from each group seed,
tric_control.selection; DPL: one model a seed) and evaluates them through the real nodes, each
evaluation kept under DIR/episodes, re-used when made as asked and continued after an interrupt
(tric_control.evaluation.kept); the candidates, trainings and episodes run on an executor
(tric_control.evaluation.executors: processes here, or Ray); all of one robot (its reference bags,
its data sets' workspace)."""

import pathlib
from dataclasses import replace

import torch

from tric_control.evaluation.executors import ProcessExecutor
from tric_control.evaluation.graph import evaluate
from tric_control.evaluation.kept import kept_evaluation
from tric_control.selection.choice import choose
from tric_control.selection.select_model import candidate_seeds
from tric_control.selection.settings import SelectionConfig
from tric_control.study.candidates import CandidateStore, key_name, rollouts_key, training_key
from tric_learning import model_file
from tric_learning.bags.loader import load_dataset
from tric_learning.model_file import ModelFile, tensor_digest
from tric_learning.training import dpl
from tric_learning.training.dataset import Dataset
from tric_learning.training.lbfgs import torch_threads
from tric_learning.training.value import TrainingConfig, train
from tric_sim.ros.dds_domains import private_domain_id
from tric_sim.tools.provenance import code_digest
from tric_sim.tools.robot_option import reference_bags
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.robot_profile import DEFAULT_ROBOT, load_profile

#: The group seeds of every model of Tables 1, 3, 4 and Exps. 4 and 5: TRIC's candidates are drawn
#: from G, G + 1, ... (a seed draws the noisy samples and the initial weights), DPL's model from G;
#: a result holds over all three independent groups, not for one draw.
SEEDS = (0, 100, 200)


def trained_model_file(
    kind: str, dataset: Dataset, config, threads: int, robot_spec: str = DEFAULT_ROBOT
):
    """The model file (model_file.ModelFile) of a training of kind ("tric" or a DPL kind) on
    dataset with config, PyTorch computing with threads threads (the caller's: the same model on
    every executor), for the robot robot_spec (a profile's name or file)."""
    robot = RobotModel(robot_spec)
    with torch_threads(threads):
        if kind == "tric":
            return model_file.from_training(train(dataset, robot, config), dataset)
        return dpl.to_model_file(dpl.train_dpl(dataset, robot, config, kind), dataset)


class Runner:
    """Trains (or re-uses) models under out/models and runs evaluations with `jobs` worker graphs,
    on private DDS domains from its own one up, keeping their episodes under out/episodes; both
    on executor (None: processes here); of robot (a profile's name or file)."""

    def __init__(self, out: pathlib.Path, jobs: int = 1, executor=None, robot: str = DEFAULT_ROBOT):
        self.out = out
        self.jobs = jobs
        self.executor = executor or ProcessExecutor()
        self.profile = load_profile(robot)
        self.robot = RobotModel(self.profile)
        self.domain_id = private_domain_id()
        self._datasets: dict[str, Dataset] = {}
        self.candidates = CandidateStore(out / "candidates", self.profile.spec)
        (out / "models").mkdir(parents=True, exist_ok=True)

    def situations(self, name: str) -> list:
        """A built-in data set in the robot's workspace."""
        return situations.dataset(name, self.profile.workspace)

    def bags(self, bags: str) -> pathlib.Path:
        """The robot's reference bags of a set (bags/<bags>, or bags/<robot>/<bags>)."""
        return reference_bags(self.profile, bags)

    def demonstrations(self, bags: str) -> Dataset:
        """The dataset of the robot's reference bags of a set, read once."""
        if bags not in self._datasets:
            self._datasets[bags] = load_dataset([self.bags(bags)], self.robot)
        return self._datasets[bags]

    def model(
        self, name: str, bags: str, kind: str = "tric", hidden_units: int = 30, seed: int = 0
    ) -> pathlib.Path:
        """The model file out/models/<name>_s<seed>.safetensors, made on the bags <bags>: TRIC
        chosen by the default selection among candidates from the group seed (the defaults but
        hidden_units; the candidates kept, see _chosen), DPL trained with the seed's initial
        weights unless a model made as asked is there (model_file.made_as: the kind,
        hyper-parameters, dataset and training code)."""
        path = self.out / "models" / f"{name}_s{seed}.safetensors"
        dataset = self.demonstrations(bags)
        if kind == "tric":
            return self._chosen(path, bags, TrainingConfig(hidden_units=hidden_units, seed=seed))
        config, code = dpl.DplConfig(seed=seed), code_digest("tric_learning.training.dpl")
        if not model_file.made_as(path, kind, config.to_dict(), dataset.fingerprint, code):
            print(f"training {name} (seed {seed}) on {self.bags(bags)}", flush=True)
            self._train(kind, dataset, config).save(path)
        return path

    def _chosen(self, path: pathlib.Path, bags: str, config: TrainingConfig) -> pathlib.Path:
        """The model at path, chosen by the default selection among the candidates from config's
        seed (the group's), each trained on the bags <bags> and rolled out from its demonstrations'
        starts: the candidates kept under out/candidates (tric_control.study.candidates), so
        that a change of the choice alone trains nothing again."""
        dataset, selection = self.demonstrations(bags), SelectionConfig()
        seeds = candidate_seeds(config, selection)
        wanted = []
        for seed in seeds:
            member = replace(config, seed=seed)
            training = training_key(member, dataset.fingerprint)
            wanted.append((training, rollouts_key(training, {}, 0), member, 0, None, 0))
        made = self.candidates.make(bags, dataset, wanted, self.executor, self.jobs)
        candidates = [made[(seed, key_name(w[1]))] for seed, w in zip(seeds, wanted)]
        failure = next((c for c in candidates if isinstance(c, Exception)), None)
        if failure is not None:
            raise failure
        choice = choose(candidates, dataset, config, selection)
        kept = path.is_file() and tensor_digest(ModelFile.load(path).arrays) == tensor_digest(
            choice.model.arrays
        )
        if not kept:
            print(f"chose {path.name}: seed {', '.join(map(str, choice.chosen))}", flush=True)
            choice.model.save(path)
        return path

    def over_seeds(
        self, tests, label: str, max_steps: int = 0, controller: dict | None = None, **model
    ) -> dict:
        """{seed: [EpisodeRecord]} of the model (Runner.model's arguments) made from each of
        SEEDS, max_steps and controller as evaluate's."""
        return {
            seed: self.evaluate(
                tests,
                self.model(**model, seed=seed),
                f"{label}, group {seed}",
                max_steps,
                controller,
            )
            for seed in SEEDS
        }

    def trained(self, name: str, dataset: Dataset, config: TrainingConfig) -> pathlib.Path:
        """The TRIC model file out/models/<name>.safetensors, one training on dataset with config
        (no choice among candidates: the paper's sweeps, Fig. 8) unless a model made as asked is
        there (model_file.made_as)."""
        path = self.out / "models" / f"{name}.safetensors"
        code = code_digest("tric_learning.training.value")
        if not model_file.made_as(path, "tric", config.to_dict(), dataset.fingerprint, code):
            print(f"training {name} on {len(dataset.demos)} demonstrations", flush=True)
            self._train("tric", dataset, config).save(path)
        return path

    def _train(self, kind: str, dataset: Dataset, config):
        """trained_model_file on the executor (a Ray task, or here); its error raised."""
        call = (kind, dataset, config, torch.get_num_threads(), self.profile.spec)
        [(_, result)] = self.executor.run_calls(trained_model_file, [call], 1)
        if isinstance(result, Exception):
            raise result
        return result

    def evaluate(self, chosen, model, desc: str, max_steps: int = 0, controller=None):
        """[EpisodeRecord] of model (None: the teacher) on the situations chosen, max_steps ticks at
        most (0: the task's default), the controller node's parameters controller (a dict; None:
        its defaults): those kept under out/episodes for the same model file, situations,
        max_steps, controller and code of the nodes that run and judge the episodes, the others
        run (kept_evaluation)."""

        def run(situations, on_record):
            return evaluate(
                situations,
                model,
                max_steps,
                domain_id=self.domain_id,
                desc=desc,
                jobs=self.jobs,
                on_record=on_record,
                executor=self.executor,
                robot=self.profile.spec,
                controller=controller,
            )

        code = code_digest("tric_control.evaluation.graph")
        folder = self.out / "episodes"
        return kept_evaluation(folder, chosen, model, max_steps, code, run, controller)
