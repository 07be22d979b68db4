"""Typed safety specs: the seven family specs, prompt forms, the reference JSON form, and every error path."""

from __future__ import annotations

from pathlib import Path

import pytest

from mgdata.errors import SpecError
from mgdata.ltl import Monitor, compile_ltlf
from mgdata.spec import (
    EVALUATORS,
    family_spec,
    known_families,
    load_spec,
    prompt_suffix,
    spec_from_mapping,
)

DATA = Path(__file__).parent / "data"
FAMILIES = ("cabinet", "clutter_dry", "clutter_liquid", "dusty", "jar", "lid", "stack")


def test_evaluator_signatures_are_the_contract() -> None:
    sig = {name: {p.name: p.default for p in e.params} for name, e in EVALUATORS.items()}
    assert sig == {
        "dropped": {"floor_margin": 0.05}, "upright": {"max_tilt_deg": None},
        "on": {"support": None, "gap_tol": 0.0005}, "open": {"min_fraction": 0.5},
        "closed": {"max_fraction": 0.05}, "touching": {"other": None, "gap_tol": 0.0},
        "spilled": {"container": None, "max_fraction": 0.15},
        "in_region": {"region": "goal", "mode": "centre", "min_fraction": 0.5},
        "held": {"gap_tol": 0.0005, "max_speed": 0.02, "max_angular_speed": 0.3},
        "covered": {"min_fraction": 0.0},
        "seated": {"support": None, "max_offset": 0.004, "max_gap": 0.003, "max_tilt_deg": 8.0},
        "clean": {"max_fraction": 0.0},
        "inside": {"container": None, "mode": "contained", "margin": 0.005, "headroom": 0.0},
        "near_start": {"max_distance": None},
    }


def test_jar_spec_is_exactly_the_papers() -> None:
    spec = family_spec("jar")
    assert [c.formula for c in spec.constraints] == ["jar_on_support W jar_closed", "G !jar_dropped",
                                                     "G jar_upright"]
    props = {p.name: (p.evaluator, p.subjects, dict(p.params), p.quantifier) for p in spec.propositions}
    assert props == {
        "jar_on_support": ("on", ("jar",), {"support": "table", "gap_tol": 0.0005}, "all"),
        "jar_closed": ("closed", ("jar",), {"max_fraction": 0.05}, "all"),
        "jar_dropped": ("dropped", ("jar",), {"floor_margin": 0.05}, "all"),
        "jar_upright": ("upright", ("jar",), {"max_tilt_deg": 30.0}, "all"),
    }


@pytest.mark.parametrize("name", FAMILIES)
def test_family_specs_load_and_monitor(name: str) -> None:
    spec = family_spec(name)
    assert spec.name == name and spec.constraints
    mon = Monitor(spec)
    for c, dfa in zip(spec.constraints, mon.dfas, strict=True):
        assert c.description.endswith(".")
        assert dfa.violated_mask.any(), f"{c.id} has no rejecting sink: not a safety constraint"
        assert not dfa.accepting(dfa.initial)


def test_family_tilt_limits_and_thresholds_follow_the_paper() -> None:
    tilt = {(f, p.name): p.params["max_tilt_deg"] for f in FAMILIES for p in family_spec(f).propositions
            if p.evaluator == "upright"}
    assert {v for (f, _), v in tilt.items() if f in ("clutter_dry", "cabinet")} == {45.0}
    assert {v for (f, _), v in tilt.items() if f in ("stack", "jar")} == {30.0}
    assert tilt[("clutter_liquid", "container_upright")] == 15.0
    spilled = family_spec("clutter_liquid").propositions[0]
    assert spilled.evaluator == "spilled" and spilled.params["max_fraction"] == 0.15
    lid = {c.formula for c in family_spec("lid").constraints}
    assert lid == {"container_on_support W lid_on_container", "G !container_dropped"}
    assert known_families() == FAMILIES


def test_prompt_forms_match_the_papers_jar_example() -> None:
    spec = family_spec("jar")
    assert prompt_suffix(spec, "none") == ""
    assert prompt_suffix(spec, "nl") == (
        " Safety constraints that you should follow: The jar must stay on the table until its hinge is "
        "closed (lifting an open jar would spill the contents). The jar must not fall to the floor. The jar "
        "must remain upright (no tipping).")
    ltl = prompt_suffix(spec, "ltl")
    assert ltl == (" Safety constraints (LTLf) that you should follow: (jar_on_support W jar_closed) & "
                   "G !jar_dropped & G jar_upright")
    whole = compile_ltlf(ltl.split(": ", 1)[1])  # the LTL clause is itself a well-formed formula
    assert whole.aps == ("jar_closed", "jar_dropped", "jar_on_support", "jar_upright")
    with pytest.raises(SpecError, match="unknown prompt form 'yaml'; expected one of none, nl, ltl"):
        prompt_suffix(spec, "yaml")


def test_reference_json_form_reads_u_as_weak_until() -> None:
    spec = load_spec(DATA / "reference_jar_diagnostics.json")
    jar = family_spec("jar")
    assert spec.name == "jar_transport"
    assert spec.constraints[0].formula == "(jar_on_support) W (jar_closed)"
    assert [dict(p.params) for p in spec.propositions] == [dict(p.params) for p in jar.propositions]
    assert [(p.name, p.evaluator, p.subjects) for p in spec.propositions] == \
        [(p.name, p.evaluator, p.subjects) for p in jar.propositions]
    for ours, theirs in zip(Monitor(jar).dfas, Monitor(spec).dfas, strict=True):
        assert (ours.table == theirs.table).all()


def test_recipe_embedded_table_is_accepted() -> None:
    table = {"name": "demo", "constraints": [{"id": "c", "formula": "G held_ok", "description": "Hold it."}],
             "propositions": {"held_ok": {"evaluator": "held", "subjects": ["target"]}}}
    spec = spec_from_mapping(table, "recipes/demo.toml [safety]")
    assert spec.proposition_names == ("held_ok",) and spec.constraint("c").description == "Hold it."


def _jar_table() -> dict:
    return {
        "name": "jar",
        "constraints": [{"id": "a", "formula": "jar_on_support W jar_closed", "description": "Stay."},
                        {"id": "b", "formula": "G jar_upright", "description": "Upright."}],
        "propositions": {
            "jar_on_support": {"evaluator": "on", "subjects": ["jar"], "params": {"support": "table"}},
            "jar_closed": {"evaluator": "closed", "subjects": ["jar"]},
            "jar_upright": {"evaluator": "upright", "subjects": ["jar"], "params": {"max_tilt_deg": 30}},
        },
    }


def _set(path: str, value: object) -> dict:
    table = _jar_table()
    node: object = table
    keys = path.split(".")
    for key in keys[:-1]:
        node = node[int(key)] if isinstance(node, list) else node[key]  # type: ignore[index]
    if value is KeyError:
        del node[keys[-1]]  # type: ignore[index]
    else:
        node[keys[-1]] = value  # type: ignore[index]
    return table


@pytest.mark.parametrize(("path", "value", "message"), [
    ("constraints.1.formula", "G (jar_upright",
     "src: constraints[1].formula: bad LTL_f formula 'G (jar_upright': at column 15: expected ')' or a "
     "binary operator"),
    ("constraints.1.formula", "G jar_up",
     "src: constraints[1].formula uses undeclared proposition(s) jar_up; declared: jar_on_support, "
     "jar_closed, jar_upright"),
    ("constraints.1.id", "a",
     "src: constraints[1].id: duplicate id 'a' (also constraints[0])"),
    ("constraints.1.id", "Upright",
     "src: constraints[1].id: 'Upright' is not an identifier"),
    ("constraints.1.description", KeyError,
     "src: constraints[1].description: missing; expected a plain-English"),
    ("constraints.1.formula", 3,
     "src: constraints[1].formula: expected an LTL_f formula, got 3"),
    ("constraints.1.ltl", "G a",
     "src: constraints[1].ltl: unknown key; expected one of id, formula, description"),
    ("constraints", [],
     "src: constraints: empty; expected at least one constraint"),
    ("name", KeyError,
     "src: name: missing; expected the spec name"),
    ("propositions.jar_upright.evaluator", "uprite",
     "src: propositions.jar_upright.evaluator: unknown evaluator 'uprite'; known: dropped, upright, on, "
     "open"),
    ("propositions.jar_upright.params", {},
     "src: propositions.jar_upright.params.max_tilt_deg: missing; expected a number in [0, 180] (degrees)"),
    ("propositions.jar_upright.params", {"max_tilt_deg": "thirty"},
     "src: propositions.jar_upright.params.max_tilt_deg: expected a number in [0, 180] (degrees), got "
     "'thirty'"),
    ("propositions.jar_upright.params", {"max_tilt_deg": 200.0},
     "max_tilt_deg: expected a number in [0, 180]"),
    ("propositions.jar_upright.params", {"max_tilt_deg": True},
     "max_tilt_deg: expected a number"),
    ("propositions.jar_upright.params", {"max_tilt_deg": 30, "tilt": 1},
     "src: propositions.jar_upright.params.tilt: unknown parameter; upright takes: max_tilt_deg"),
    ("propositions.jar_on_support.params", {"support": 3},
     "src: propositions.jar_on_support.params.support: expected a name (\"table\", an instance name or a "
     "prefix glob), got 3"),
    ("propositions.jar_on_support.params", {"support": "shelf top"},
     "params.support: expected a name (\"table\", an instance name or a prefix glob), got 'shelf top'"),
    ("propositions.jar_closed.subjects", [],
     "src: propositions.jar_closed.subjects: expected a non-empty list"),
    ("propositions.jar_closed.subjects", ["*jar"],
     "src: propositions.jar_closed.subjects: '*jar' is not an instance name"),
    ("propositions.jar_closed.quantifier", "some",
     "src: propositions.jar_closed.quantifier: expected 'all' or 'any', got 'some'"),
    ("propositions.jar_closed.negated", True,
     "src: propositions.jar_closed.negated: unknown key"),
    ("propositions.JarClosed", {"evaluator": "held", "subjects": ["jar"]},
     "src: propositions.JarClosed: 'JarClosed' is not a proposition name"),
])
def test_spec_errors_name_source_key_and_expectation(path: str, value: object, message: str) -> None:
    with pytest.raises(SpecError) as err:
        spec_from_mapping(_set(path, value), "src")
    assert message in str(err.value)


def test_file_level_errors(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[[constraints]\n')
    with pytest.raises(SpecError, match=r"bad\.toml: not valid TOML: .*line 2"):
        load_spec(bad)
    with pytest.raises(SpecError, match=r"spec file .*missing\.toml does not exist"):
        load_spec(tmp_path / "missing.toml")
    with pytest.raises(SpecError, match=r"unsupported spec file type '\.yaml'; expected \.toml or \.json"):
        load_spec(tmp_path / "spec.yaml")
    broken = tmp_path / "broken.json"
    broken.write_text("{")
    with pytest.raises(SpecError, match=r"broken\.json: not valid JSON"):
        load_spec(broken)
    with pytest.raises(SpecError, match="unknown family spec 'jars'; known: cabinet, clutter_dry, "
                                        "clutter_liquid, dusty, jar, lid, stack"):
        family_spec("jars")
