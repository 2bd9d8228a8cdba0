"""PyBullet, imported without what its C code prints on stdout (its build time), and quiet_stdout()
to silence it around other chatty calls (URDF loading, which reports link merging)."""

import contextlib
import os

__all__ = ["pb", "quiet_stdout"]


@contextlib.contextmanager
def quiet_stdout():
    """Silence what PyBullet's C code prints on stdout (build time, URDF link merging)."""
    try:
        saved = os.dup(1)
    except OSError:  # no stdout to silence
        yield
        return
    with open(os.devnull, "wb") as devnull:
        os.dup2(devnull.fileno(), 1)
        try:
            yield
        finally:
            os.dup2(saved, 1)
            os.close(saved)


with quiet_stdout():
    import pybullet as pb
