"""The labelling function: registry matches the spec's evaluator list, quantifiers, globs, clear errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.errors import SpecError
from mgdata.sim.labelling import Labeller
from mgdata.sim.predicates import FACTORIES
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.spec import EVALUATORS, Proposition, SafetySpec
from tests.helpers.sim_tasks import task_with


def spec_of(*props: Proposition) -> SafetySpec:
    return SafetySpec("t", (), props)


@pytest.fixture(scope="module")
def cups() -> Scene:
    return build_scene(task_with(ObjectPlacement("cup_0", "cup/tumbler_00", (0.5, -0.2, 0.0)),
                                 ObjectPlacement("cup_1", "cup/tumbler_01", (0.5, 0.2, 0.0)),
                                 ObjectPlacement("plate", "plate/flat_00", (0.75, 0.0, 0.0))))


def test_registry_implements_exactly_the_declared_evaluators() -> None:
    assert set(FACTORIES) == set(EVALUATORS)


def test_globs_and_quantifiers(cups: Scene) -> None:
    cups.reset()
    up = {"max_tilt_deg": 30.0}
    lab = Labeller(cups, spec_of(Proposition("all_up", "upright", ("cup_*",), up),
                                 Proposition("any_up", "upright", ("cup_*",), up, quantifier="any"),
                                 Proposition("on_table", "on", ("cup_*", "plate"), {"support": "table"})))
    assert lab.as_dict() == {"all_up": True, "any_up": True, "on_table": True}
    adr = cups.model.jnt_qposadr[cups.model.joint("cup_1/free").id]
    cups.data.qpos[adr + 2] = 0.2  # lift cup_1 and lay it on its side, in the air
    cups.data.qpos[adr + 3 : adr + 7] = [np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0]
    mujoco.mj_forward(cups.model, cups.data)
    assert lab.as_dict() == {"all_up": False, "any_up": True, "on_table": False}


@pytest.mark.parametrize(
    ("prop", "message"),
    [
        (Proposition("p", "upright", (), {"max_tilt_deg": 30.0}), "no subjects"),
        (Proposition("p", "upright", ("mug_*",), {"max_tilt_deg": 30.0}), "'mug_\\*' matches no object"),
        (Proposition("p", "upright", ("cup_0",)), "max_tilt_deg: missing"),
        (Proposition("p", "upright", ("cup_0",), {"max_tilt": 30.0}), "unknown parameter"),
        (Proposition("p", "levitating", ("cup_0",)), "unknown evaluator 'levitating'"),
        (Proposition("p", "upright", ("cup_0",), {"max_tilt_deg": 30.0}, quantifier="most"), "or 'any'"),
        (Proposition("p", "on", ("cup_0",), {"support": "shelf"}), "support 'shelf' matches no object"),
        (Proposition("p", "closed", ("cup_0",)), "has no articulation"),
        (Proposition("p", "spilled", ("cup_0",), {"container": "plate"}), "not a liquid"),
        (Proposition("p", "in_region", ("cup_0",)), "no region 'goal'"),
        (Proposition("p", "covered", ("plate",)), "no dust lies on 'plate'"),
    ],
)
def test_bad_propositions_are_clear_errors(cups: Scene, prop: Proposition, message: str) -> None:
    with pytest.raises(SpecError, match=message):
        Labeller(cups, spec_of(prop))


def test_duplicate_proposition_names_are_rejected(cups: Scene) -> None:
    p = Proposition("p", "upright", ("cup_0",), {"max_tilt_deg": 30.0})
    with pytest.raises(SpecError, match="twice"):
        Labeller(cups, spec_of(p, p))
