"""Full-category validation on one model of each category (slow: about two minutes per category on a quiet
machine): the categories the generator covers must have at least one grasp that lifts the object (or pulls
the drawer open) in simulation."""

from __future__ import annotations

import pytest

from mgdata.grasps.candidates import CandidateConfig, candidates
from mgdata.grasps.check import GraspCheckConfig, check_grasp
from mgdata.sim.assets import get_model

COVERED = ("cup/tumbler_07", "mug/handled_07", "teacup/flared_07", "bottle/round_07", "box/carton_07",
           "bowl/round_05", "container/tub_07", "lid/tub_07", "sponge/block_07", "cabinet/drawer_07")


@pytest.mark.slow
@pytest.mark.parametrize("model", COVERED)
def test_every_covered_category_has_a_valid_grasp(model: str) -> None:
    grasps = candidates(get_model(model), CandidateConfig())
    results = [check_grasp(model, g, GraspCheckConfig()) for g in grasps]
    assert any(status == "valid" for status, _ in results), results
