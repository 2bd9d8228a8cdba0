"""The optimizer that TRIC's training and DPL's share: L-BFGS with a strong-Wolfe line search on the
full batch (minimize_lbfgs), run within PyTorch's deterministic algorithms (deterministic_torch), so
that the same seed gives the same weights on a given machine, run after run
(docs/decisions/seed-lottery.md)."""

import contextlib

import torch


def minimize_lbfgs(theta, loss, max_iterations: int, tolerance_change: float) -> int:
    """Minimize loss(iteration), a scalar tensor of the parameters theta (1-D, requires grad), in
    place by L-BFGS with a strong-Wolfe line search (history 20, at most max_iterations iterations
    and twice as many evaluations; stops when the gradient's largest entry is below 1e-10 or the
    loss changes by less than tolerance_change). loss gets the iterations done so far, for
    progress reports. Returns the iterations done."""
    optimizer = torch.optim.LBFGS(
        [theta],
        lr=1.0,
        max_iter=max_iterations,
        max_eval=max_iterations * 2,
        history_size=20,
        tolerance_grad=1e-10,
        tolerance_change=tolerance_change,
        line_search_fn="strong_wolfe",
    )

    def closure():
        optimizer.zero_grad()
        total = loss(optimizer.state[theta].get("n_iter", 0))
        total.backward()
        return total

    optimizer.step(closure)
    return optimizer.state[theta].get("n_iter", 0)


@contextlib.contextmanager
def deterministic_torch():
    """Within the block PyTorch uses only its deterministic algorithms (no run-to-run differences of
    its multi-threaded accumulations); the previous setting is restored after it."""
    previous = torch.are_deterministic_algorithms_enabled()
    torch.use_deterministic_algorithms(True)
    try:
        yield
    finally:
        torch.use_deterministic_algorithms(previous)


@contextlib.contextmanager
def torch_threads(count: int):
    """Within the block PyTorch computes with count threads (a model's float rounding depends on
    it: a training that is to give the same model wherever it runs fixes it); restored after."""
    previous = torch.get_num_threads()
    torch.set_num_threads(count)
    try:
        yield
    finally:
        torch.set_num_threads(previous)
