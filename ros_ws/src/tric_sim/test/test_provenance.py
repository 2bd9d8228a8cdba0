"""What code made a result (tric_sim.tools.provenance): the imports a source names, and a digest
that follows the project's modules a module imports, directly or not."""

import pytest

from tric_sim.tools import provenance


def test_imports_are_read_from_the_source_relative_ones_resolved():
    source = b"""
import numpy as np
import tric_sim.world.scene
from tric_learning import samples, features as f
from . import sibling
from ..up import thing
"""
    names = provenance.imported_modules(source, "tric_learning.analysis")
    assert names == [
        "numpy",
        "tric_sim.world.scene",
        "tric_learning",
        "tric_learning.samples",
        "tric_learning.features",
        "tric_learning.analysis",
        "tric_learning.analysis.sibling",
        "tric_learning.up",
        "tric_learning.up.thing",
    ]


def test_the_digest_follows_imports_and_names_only_project_modules():
    digest = provenance.code_digest("tric_sim.world.collision")
    assert len(digest) == provenance.DIGEST_LENGTH and digest == provenance.code_digest(
        "tric_sim.world.collision"
    )
    # collision imports scene, so a digest of both is the digest of collision alone
    assert provenance.code_digest("tric_sim.world.collision", "tric_sim.world.scene") == digest
    assert provenance.code_digest("tric_sim.world.scene") != digest
    assert (
        provenance.module_file("tric_sim.world.scene.scene_bodies") is None
    )  # a function, not a module
    with pytest.raises(ValueError, match="numpy is not a module of tric_sim"):
        provenance.code_digest("numpy")
