"""Choosing a TRIC model: candidates trained side by side from one group seed, each rolled out from
its demonstrations' start situations, scored by how closely each rollout ended where its
demonstration ended, and the best kept, or the best N as an ensemble (candidates, rollouts,
scores, choice). The default score reads the demonstrations and the rollouts only, never the
task's hidden metrics (docs/decisions/model-selection.md)."""
