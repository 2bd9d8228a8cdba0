"""How a training chooses its model (SelectionConfig): how many candidates, how many of the best
kept as an ensemble, and the score that ranks them. Light: the tools check these options before
the heavy libraries load."""

from dataclasses import asdict, dataclass

#: The scores that rank candidates (tric_control.selection.scores); the judge's read the task's
#: hidden metrics and are never the default.
SCORES = ("landmarks", "features", "joints", "value", "judge", "successes")
JUDGE_SCORES = ("judge", "successes")
#: The selection a training makes unless told otherwise (docs/decisions/model-selection.md).
DEFAULT_CANDIDATES = 8
DEFAULT_MEMBERS = 1
DEFAULT_SCORE = "landmarks"
#: PyTorch's threads in every candidate's training: the same model on every executor and core
#: count, and candidates that train side by side on one CPU each.
CANDIDATE_THREADS = 1


@dataclass(frozen=True)
class SelectionConfig:
    """candidates: S models trained with the seeds G, G + 1, ..., G + S - 1 (G: the training's
    seed). members: the best N of them kept, averaged into one f when N > 1. score: the name of the
    score that ranks them (SCORES)."""

    candidates: int = DEFAULT_CANDIDATES
    members: int = DEFAULT_MEMBERS
    score: str = DEFAULT_SCORE

    def validate(self) -> "SelectionConfig":
        """Return self, or ValueError naming the first value out of range."""
        if not 1 <= self.candidates <= 64:
            raise ValueError("candidates must be in [1, 64]")
        if not 1 <= self.members <= self.candidates:
            raise ValueError(f"members must be in [1, candidates ({self.candidates})]")
        if self.score not in SCORES:
            raise ValueError(f"the selection score must be one of {', '.join(SCORES)}")
        return self

    @property
    def uses_judge(self) -> bool:
        """Whether the score reads the task's hidden metrics."""
        return self.score in JUDGE_SCORES

    @property
    def reads_lift_test(self) -> bool:
        """Whether the score reads the grasp rollouts' lift test ("successes": a good grasp that
        held); the selection's rollouts leave the test out otherwise."""
        return self.score == "successes"

    def to_dict(self) -> dict:
        return asdict(self)
