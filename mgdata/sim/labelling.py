"""The labelling function L: a scene state -> the truth of every proposition of a safety spec.

``Labeller(scene, spec)`` compiles each proposition once (subjects resolved, ids precomputed); ``labels()``
then evaluates them on the scene's current state in ``spec.proposition_names`` order. A proposition over
several subjects combines them with its quantifier (``all`` or ``any``); a subject pattern that matches
nothing is an error at construction, never a silent True or False.

Example::

    lab = Labeller(scene, task.safety)
    bits = lab.labels()          # bool (n_props,)
    dict(zip(lab.names, bits))
"""

from __future__ import annotations

import numpy as np

from mgdata.errors import SpecError
from mgdata.sim.predicates import Check, Contacts, compile_check, resolve
from mgdata.sim.scene import Scene
from mgdata.spec import Proposition, SafetySpec, proposition_from_mapping


def _validated(prop: Proposition, where: str) -> Proposition:
    """The proposition checked against ``mgdata.spec.EVALUATORS`` (specs built in code skip the loader)."""
    if not prop.subjects:
        raise SpecError(f"{where}: no subjects (an empty subject set has no truth value)")
    table = {"evaluator": prop.evaluator, "subjects": list(prop.subjects), "params": dict(prop.params),
             "quantifier": prop.quantifier}
    return proposition_from_mapping(prop.name, table, where)


class Labeller:
    """Evaluates a spec's propositions on a scene.

    Attributes:
        names: proposition names, the order of :meth:`labels`.
    """

    def __init__(self, scene: Scene, spec: SafetySpec) -> None:
        self.scene = scene
        self.spec = spec
        self.names: tuple[str, ...] = spec.proposition_names
        if len(set(self.names)) != len(self.names):
            raise SpecError(f"spec {spec.name!r} declares a proposition name twice: {', '.join(self.names)}")
        self._checks: list[tuple[bool, tuple[Check, ...]]] = []
        for raw in spec.propositions:
            where = f"spec {spec.name!r}, proposition {raw.name!r}"
            prop = _validated(raw, where)
            subjects = [n for pattern in prop.subjects for n in resolve(scene, pattern, f"{where}: subject")]
            checks = tuple(compile_check(scene, prop.evaluator, s, prop.params) for s in subjects)
            self._checks.append((prop.quantifier == "all", checks))

    def labels(self, contacts: Contacts | None = None) -> np.ndarray:
        """Truth of every proposition on the scene's current state, bool (n_props,).

        ``contacts`` may pass a :class:`Contacts` view of the current state already built by the caller.
        """
        contacts = contacts or Contacts(self.scene)
        out = np.empty(len(self._checks), dtype=bool)
        for i, (universal, checks) in enumerate(self._checks):
            if universal:
                out[i] = all(check(contacts) for check in checks)
            else:
                out[i] = any(check(contacts) for check in checks)
        return out

    def as_dict(self) -> dict[str, bool]:
        """``labels()`` keyed by proposition name (for logs and tests)."""
        return dict(zip(self.names, self.labels().tolist(), strict=True))
