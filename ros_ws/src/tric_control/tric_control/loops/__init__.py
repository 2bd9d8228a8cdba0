"""The controller node's loops: an episode's bookkeeping, and its lockstep and realtime loops."""
