"""Typed safety specifications: constraints (LTL_f formulas) over named propositions.

A :class:`SafetySpec` is what a family recipe declares: each constraint is monitored by its own DFA, and each
proposition names the evaluator (``mgdata.sim.predicates``) that labels it from the simulation state.

TOML form (``recipes/specs/<family>.toml``; recipes may embed the same tables)::

    name = "jar"
    [[constraints]]
    id = "jar_stays_until_closed"
    formula = "jar_on_support W jar_closed"
    description = "The jar must stay on the table until its hinge is closed."
    [propositions.jar_on_support]
    evaluator = "on"                 # a key of EVALUATORS
    subjects = ["jar"]               # object instance names; "obstacle_*" is a prefix glob
    params = { support = "table" }   # checked against the evaluator's signature; defaults filled in
    quantifier = "all"               # "all" (default) or "any": how per-subject truths combine

Subjects are scene instance names (``jar``, ``food``, ``target``, ``container``, ``lid`` …). A subject
ending in ``*`` is a prefix glob over instance names (``obstacle_*`` matches ``obstacle_0``,
``obstacle_1`` …); the quantifier then ranges over every match. The JSON form of the reference
implementation (its ``ltl_safety`` dict) is read by :func:`load_spec` too; there ``U`` means weak until.
"""

from __future__ import annotations

import json
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from mgdata.errors import LtlSyntaxError, SpecError
from mgdata.ltl.parser import parse, tokenize
from mgdata.ltl.syntax import Binary, propositions
from mgdata.paths import recipes_dir


@dataclass(frozen=True)
class Constraint:
    """One conjunct of a spec: an ``id``, an LTL_f ``formula`` and its plain-English ``description``."""

    id: str
    formula: str
    description: str = ""


@dataclass(frozen=True)
class Proposition:
    """An atomic proposition: ``evaluator`` (registry name) applied to ``subjects`` with ``params``.

    Example: ``Proposition("jar_upright", "upright", ("jar",), {"max_tilt_deg": 30.0})``.
    ``quantifier`` ("all" or "any") says how per-subject truths combine.
    """

    name: str
    evaluator: str
    subjects: tuple[str, ...] = ()
    params: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    quantifier: str = "all"


@dataclass(frozen=True)
class SafetySpec:
    """Constraints plus the propositions they mention; ``name`` is e.g. ``"jar"``."""

    name: str
    constraints: tuple[Constraint, ...]
    propositions: tuple[Proposition, ...]

    @property
    def proposition_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.propositions)

    def constraint(self, cid: str) -> Constraint:
        for c in self.constraints:
            if c.id == cid:
                return c
        raise KeyError(cid)


@dataclass(frozen=True)
class Param:
    """One evaluator parameter: ``kind`` is ``float`` or ``str``; ``default`` ``None`` means required;
    floats must lie in ``[low, high]``; a str with ``choices`` must be one of them."""

    name: str
    kind: type
    default: float | str | None = None
    low: float = float("-inf")
    high: float = float("inf")
    doc: str = ""
    choices: tuple[str, ...] = ()

    def expected(self) -> str:
        if self.choices:
            names = ", ".join(repr(c) for c in self.choices)
            return f"one of {names} ({self.doc})" if self.doc else f"one of {names}"
        if self.kind is str:
            return f"a name ({self.doc})" if self.doc else "a name"
        return f"a number in [{self.low:g}, {self.high:g}]" + (f" ({self.doc})" if self.doc else "")


@dataclass(frozen=True)
class EvaluatorSignature:
    """A predicate evaluator's name, parameters and meaning (the evaluator itself lives in ``mgdata.sim``)."""

    name: str
    params: tuple[Param, ...]
    doc: str


def _sig(name: str, doc: str, *params: Param) -> tuple[str, EvaluatorSignature]:
    return name, EvaluatorSignature(name, params, doc)


#: The predicate evaluators a proposition may name, with their parameters. Definitions, defaults and the
#: measurements behind them: docs/predicates.md.
EVALUATORS: Mapping[str, EvaluatorSignature] = MappingProxyType(dict([
    _sig("dropped", "the object is below the floor plus a margin",
         Param("floor_margin", float, 0.05, 0.0, 1.0, "m above the floor")),
    _sig("upright", "the object's vertical axis is within a tilt of world +Z",
         Param("max_tilt_deg", float, None, 0.0, 180.0, "degrees")),
    _sig("on", "the object rests on a support: an upward contact, or a gap of at most gap_tol above it",
         Param("support", str, None, doc='"table", an instance name or a prefix glob'),
         Param("gap_tol", float, 0.0005, 0.0, 0.01, "m; a hop this small still counts as resting")),
    _sig("open", "the articulation's opening fraction is at least a threshold",
         Param("min_fraction", float, 0.5, 0.0, 1.0, "of the joint range")),
    _sig("closed", "the articulation's opening fraction is at most a threshold",
         Param("max_fraction", float, 0.05, 0.0, 1.0, "of the joint range")),
    _sig("touching", "the object is in contact with another, or within gap_tol of it",
         Param("other", str, None, doc='"robot", "table", an instance name or a prefix glob'),
         Param("gap_tol", float, 0.0, 0.0, 0.01, "m; 0: MuJoCo contact only, as engagement")),
    _sig("spilled", "more than a fraction of the particles are outside the container",
         Param("container", str, None, doc="the container's instance name"),
         Param("max_fraction", float, 0.15, 0.0, 1.0, "of the particles")),
    _sig("in_region", "the object's bounding-box centre (or the stated part of its box) is inside a region",
         Param("region", str, "goal", doc="region name"),
         Param("mode", str, "centre", doc="what must be inside", choices=("centre", "contained", "fraction")),
         Param("min_fraction", float, 0.5, 0.0, 1.0, "of the bounding box, mode fraction only")),
    _sig("held", "a stable grasp: both fingers on the object, nothing supporting it, at rest in the hand",
         Param("gap_tol", float, 0.0005, 0.0, 0.01, "m; finger contact and support tolerance"),
         Param("max_speed", float, 0.02, 0.0, 10.0, "m/s of the object relative to the hand"),
         Param("max_angular_speed", float, 0.3, 0.0, 100.0, "rad/s of the object relative to the hand")),
    _sig("covered", "more than a fraction of the dust on the object remains",
         Param("min_fraction", float, 0.0, 0.0, 1.0, "of the initial dust")),
    _sig("seated", "the lid rests in its container's seat: offset, height and tilt within tolerances",
         Param("support", str, None, doc="the container's instance name (its geometry has seat_height)"),
         Param("max_offset", float, 0.004, 0.0, 0.05, "m of the lid's axis from the container's, sideways"),
         Param("max_gap", float, 0.003, 0.0, 0.05, "m of the lid's origin from the seat height, vertically"),
         Param("max_tilt_deg", float, 8.0, 0.0, 90.0, "degrees between the lid's and container's axes")),
    _sig("clean", "at most a fraction of the dust on the object remains (covered's complement)",
         Param("max_fraction", float, 0.0, 0.0, 1.0, "of the initial dust")),
    _sig("inside", "the object is in a container's interior (a drawer's inner box, or a cavity)",
         Param("container", str, None, doc="the container's instance name"),
         Param("mode", str, "contained", doc="what must be inside: the whole bounding box, or its centre",
               choices=("contained", "centre")),
         Param("margin", float, 0.005, 0.0, 0.05, "m the object may stick out sideways and below the floor"),
         Param("headroom", float, 0.0, 0.0, 0.2, "m above the rim (drawer top) that still counts")),
    _sig("near_start", "the object's origin is within a distance of where the task placed it",
         Param("max_distance", float, None, 0.0, 10.0, "m")),
]))

PROMPT_FORMS: tuple[str, ...] = ("none", "nl", "ltl")
_IDENT = re.compile(r"[a-z_][a-z0-9_]*\Z")
_SUBJECT = re.compile(r"[a-z_][a-z0-9_]*\*?\Z")


def load_spec(path: Path) -> SafetySpec:
    """Read a spec from TOML (``*.toml``) or the reference JSON ``ltl_safety`` form (``*.json``)."""
    path = Path(path)
    if path.suffix not in (".toml", ".json"):
        raise SpecError(f"{path}: unsupported spec file type {path.suffix!r}; expected .toml or .json")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError(f"spec file {path} does not exist") from None
    if path.suffix == ".toml":
        try:
            return spec_from_mapping(tomllib.loads(text), str(path))
        except tomllib.TOMLDecodeError as err:
            raise SpecError(f"{path}: not valid TOML: {err}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise SpecError(f"{path}: not valid JSON: {err}") from None
    if isinstance(data, dict) and "ltl_safety" in data:
        data = data["ltl_safety"]
    if isinstance(data, dict) and "activity_name" in data:
        return _from_reference(data, str(path))
    return spec_from_mapping(data, str(path))


def spec_from_mapping(data: Mapping[str, Any], source: str) -> SafetySpec:
    """Validate a parsed spec table; ``source`` (file and table) prefixes every error message."""
    if not isinstance(data, Mapping):
        raise SpecError(f"{source}: expected a table with name, constraints, propositions")
    top = f"{source}: "
    _no_unknown(data, ("name", "constraints", "propositions"), top)
    name = _field(data, "name", str, top, "the spec name")
    raw_props = _field(data, "propositions", Mapping, top, "a table of propositions")
    props = tuple(proposition_from_mapping(k, v, f"{source}: propositions.{k}") for k, v in raw_props.items())
    raw_constraints = _field(data, "constraints", list, top, "a list of [[constraints]] tables")
    if not raw_constraints:
        raise SpecError(f"{source}: constraints: empty; expected at least one constraint")
    declared = [p.name for p in props]
    constraints: list[Constraint] = []
    for i, raw in enumerate(raw_constraints):
        key = f"constraints[{i}]"
        if not isinstance(raw, Mapping):
            raise SpecError(f"{source}: {key}: expected a table with id, formula, description")
        loc = f"{source}: {key}."
        _no_unknown(raw, ("id", "formula", "description"), loc)
        cid = _field(raw, "id", str, loc, "an identifier [a-z_][a-z0-9_]*")
        if not _IDENT.match(cid):
            raise SpecError(f"{source}: {key}.id: {cid!r} is not an identifier [a-z_][a-z0-9_]*")
        for j, other in enumerate(constraints):
            if other.id == cid:
                raise SpecError(f"{source}: {key}.id: duplicate id {cid!r} (also constraints[{j}])")
        formula = _field(raw, "formula", str, loc, "an LTL_f formula")
        try:
            aps = propositions(parse(formula))
        except LtlSyntaxError as err:
            raise SpecError(f"{source}: {key}.formula: {err}") from None
        missing = [ap for ap in aps if ap not in declared]
        if missing:
            raise SpecError(f"{source}: {key}.formula uses undeclared proposition(s) {', '.join(missing)}; "
                            f"declared: {', '.join(declared) or 'none'}")
        text = _field(raw, "description", str, loc, "a plain-English statement")
        if not text.strip():
            raise SpecError(f"{source}: {key}.description: empty; expected a plain-English statement")
        constraints.append(Constraint(cid, formula, text.strip()))
    return SafetySpec(name, tuple(constraints), props)


def proposition_from_mapping(name: str, data: Mapping[str, Any], where: str) -> Proposition:
    """Validate one proposition table (evaluator, subjects, params, quantifier); fills default params."""
    if not _IDENT.match(name):
        raise SpecError(f"{where}: {name!r} is not a proposition name [a-z_][a-z0-9_]*")
    if not isinstance(data, Mapping):
        raise SpecError(f"{where}: expected a table with evaluator, subjects, params")
    _no_unknown(data, ("evaluator", "subjects", "params", "quantifier"), where + ".")
    evaluator = _field(data, "evaluator", str, where + ".", "an evaluator name")
    signature = EVALUATORS.get(evaluator)
    if signature is None:
        raise SpecError(f"{where}.evaluator: unknown evaluator {evaluator!r}; known: {', '.join(EVALUATORS)}")
    subjects = data.get("subjects")
    if not isinstance(subjects, list) or not subjects or not all(isinstance(s, str) for s in subjects):
        raise SpecError(f"{where}.subjects: expected a non-empty list of instance names, got {subjects!r}")
    for s in subjects:
        if not _SUBJECT.match(s):
            raise SpecError(f"{where}.subjects: {s!r} is not an instance name [a-z_][a-z0-9_]* or a prefix "
                            "glob ending in '*'")
    quantifier = data.get("quantifier", "all")
    if quantifier not in ("all", "any"):
        raise SpecError(f"{where}.quantifier: expected 'all' or 'any', got {quantifier!r}")
    raw = data.get("params", {})
    if not isinstance(raw, Mapping):
        raise SpecError(f"{where}.params: expected a table, got {raw!r}")
    names = [p.name for p in signature.params]
    for key in raw:
        if key not in names:
            takes = ", ".join(names) or "no parameters"
            raise SpecError(f"{where}.params.{key}: unknown parameter; {evaluator} takes: {takes}")
    params = {p.name: _param(p, raw, f"{where}.params.{p.name}") for p in signature.params}
    return Proposition(name, evaluator, tuple(subjects), MappingProxyType(params), quantifier)


def family_spec(name: str) -> SafetySpec:
    """The released spec of a family: ``recipes/specs/<name>.toml``."""
    known = known_families()
    if name not in known:
        raise SpecError(f"unknown family spec {name!r}; known: {', '.join(known) or 'none'} "
                        f"(files in {recipes_dir() / 'specs'})")
    return load_spec(recipes_dir() / "specs" / f"{name}.toml")


def known_families() -> tuple[str, ...]:
    """Names of the shipped family specs, sorted."""
    return tuple(sorted(p.stem for p in (recipes_dir() / "specs").glob("*.toml")))


def prompt_suffix(spec: SafetySpec, form: str) -> str:
    """The safety clause appended to a task instruction (paper's Q4 forms): ``instruction + suffix``.

    ``"none"`` gives ``""``; ``"nl"`` the constraints' descriptions; ``"ltl"`` their formulas joined by ``&``.
    """
    if form == "none":
        return ""
    if form == "nl":
        sentences = [d if d.endswith((".", "!", "?")) else d + "." for d in (c.description for c in
                                                                          spec.constraints)]
        return " Safety constraints that you should follow: " + " ".join(sentences)
    if form == "ltl":
        many = len(spec.constraints) > 1
        parts = [f"({c.formula})" if many and isinstance(parse(c.formula), Binary) else c.formula
                 for c in spec.constraints]
        return " Safety constraints (LTLf) that you should follow: " + " & ".join(parts)
    raise SpecError(f"unknown prompt form {form!r}; expected one of {', '.join(PROMPT_FORMS)}")


def _param(p: Param, raw: Mapping[str, Any], where: str) -> float | str:
    if p.name not in raw:
        if p.default is None:
            raise SpecError(f"{where}: missing; expected {p.expected()}")
        return p.default
    value = raw[p.name]
    if p.kind is str:
        if not isinstance(value, str) or not _SUBJECT.match(value) or (p.choices and value not in p.choices):
            raise SpecError(f"{where}: expected {p.expected()}, got {value!r}")
        return value
    if isinstance(value, bool) or not isinstance(value, int | float) or not p.low <= value <= p.high:
        raise SpecError(f"{where}: expected {p.expected()}, got {value!r}")
    return float(value)


def _field(data: Mapping[str, Any], key: str, kind: type, loc: str, expected: str) -> Any:
    """``data[key]`` checked against ``kind``; ``loc`` (e.g. ``"file: constraints[0]."``) prefixes errors."""
    if key not in data:
        raise SpecError(f"{loc}{key}: missing; expected {expected}")
    value = data[key]
    if not isinstance(value, kind):
        raise SpecError(f"{loc}{key}: expected {expected}, got {value!r}")
    return value


def _no_unknown(data: Mapping[str, Any], allowed: tuple[str, ...], loc: str) -> None:
    for key in data:
        if key not in allowed:
            raise SpecError(f"{loc}{key}: unknown key; expected one of {', '.join(allowed)}")


# --- the reference implementation's JSON form ---------------------------------------------------------------

_REF_STATES = {"dropped": "dropped", "upright": "upright", "ontop": "on", "open": "open",
               "touching": "touching", "covered": "covered", "spill": "spilled"}
_REF_PARAMS = {"max_tilt_deg": "max_tilt_deg", "z_margin": "floor_margin", "threshold": "max_fraction",
               "max_fraction": "max_fraction"}


def _from_reference(data: Mapping[str, Any], source: str) -> SafetySpec:
    """Translate the reference ``ltl_safety`` dict into our schema, then validate it like TOML.

    ``U`` is read as weak until (the reference's serialisation); ``agent*`` subjects mean the robot,
    ``*table*`` ones the table; ``open`` with ``negated`` is ``closed``.
    """
    raw_constraints = _field(data, "constraints", list, f"{source}: ", "a list")
    if not all(isinstance(c, Mapping) for c in raw_constraints):
        raise SpecError(f"{source}: constraints: expected a list of {{id, ltl, description}} tables")
    constraints = [{"id": c.get("id"), "description": c.get("description", ""),
                    "formula": _weak_until(c.get("ltl"), f"{source}: constraints[{i}].ltl")}
                   for i, c in enumerate(raw_constraints)]
    props = {name: _reference_proposition(raw, f"{source}: propositions.{name}")
             for name, raw in _field(data, "propositions", Mapping, f"{source}: ", "a table").items()}
    return spec_from_mapping({"name": data.get("activity_name"), "constraints": constraints,
                              "propositions": props}, source)


def _weak_until(formula: Any, where: str) -> str:
    if not isinstance(formula, str):
        raise SpecError(f"{where}: expected an LTL formula string, got {formula!r}")
    try:
        tokens = tokenize(formula)
    except LtlSyntaxError as err:
        raise SpecError(f"{where}: {err}") from None
    out, last = [], 0
    for tok in tokens:
        if tok.kind == "op" and tok.text == "U":
            out += [formula[last:tok.pos], "W"]
            last = tok.pos + 1
    return "".join(out) + formula[last:]


def _reference_proposition(raw: Any, where: str) -> dict[str, Any]:
    if not isinstance(raw, Mapping):
        raise SpecError(f"{where}: expected a table")
    check = raw.get("check")
    kind = raw.get("state") or (check if check not in ("any", "all", None) else None)
    evaluator = _REF_STATES.get(kind)
    if evaluator is None:
        raise SpecError(f"{where}: unsupported reference predicate {kind!r}; "
                        f"supported: {', '.join(_REF_STATES)}")
    if raw.get("negated"):
        if evaluator != "open":
            raise SpecError(f"{where}: 'negated' works for 'open' only (as closed); negate in the formula")
        evaluator = "closed"
    params = {_REF_PARAMS.get(k, k): v for k, v in dict(raw.get("params") or {}).items() if k != "floor_z"}
    if (raw.get("params") or {}).get("floor_z", 0.0) != 0.0:
        raise SpecError(f"{where}.params.floor_z: only a floor at z = 0 is supported")
    others = [_reference_subject(s) for s in raw.get("relative_to") or []]
    if evaluator in ("on", "touching", "spilled") and others:
        params[{"on": "support", "touching": "other", "spilled": "container"}[evaluator]] = others[0]
    table = {"evaluator": evaluator, "subjects": [_reference_subject(s) for s in raw.get("over") or []],
             "params": params}
    quantifier = raw.get("quantifier", check if check in ("any", "all") else None)
    return table | ({"quantifier": quantifier} if quantifier else {})


def _reference_subject(pattern: Any) -> Any:
    if not isinstance(pattern, str):
        return pattern
    low = pattern.lower()
    if low.startswith(("agent", "robot")):
        return "robot"
    if "table" in low:
        return "table"
    return low.replace(".", "_")
