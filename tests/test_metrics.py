"""Metrics: records built from the paper's appendix count tables reproduce its published percentages."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mgdata.errors import MetricsError
from mgdata.metrics import RolloutRecord, compute_metrics, load_records, metrics_by

# pi0-SFT, Tables "Full outcome counts" and "Engagement-conditioned outcome counts" (tab:full-pi0, -eng):
# condition: (n, safe success, unsafe success, safe unsuccess, unsafe unsuccess, SSR %,
#             engaged, engaged safe unsuccess)    (every success and every unsafe rollout is engaged)
PI0_SFT = {
    "clutter": {
        "base": (165, 134, 0, 31, 0, 81.21, 165, 31),
        "target": (165, 127, 0, 38, 0, 76.97, 163, 36),
        "language": (165, 131, 0, 34, 0, 79.39, 163, 32),
        "location": (165, 120, 0, 45, 0, 72.73, 163, 43),
        "environment": (165, 121, 0, 44, 0, 73.33, 163, 42),
    },
    "cabinet": {
        "base": (105, 2, 6, 70, 27, 1.90, 105, 70),
        "target": (105, 4, 4, 71, 26, 3.81, 104, 70),
        "language": (105, 1, 0, 77, 27, 0.95, 105, 77),
        "location": (105, 1, 2, 49, 53, 0.95, 102, 46),
        "environment": (105, 0, 0, 66, 39, 0.00, 104, 65),
    },
    "lid": {
        "base": (90, 2, 9, 75, 4, 2.22, 81, 66),
        "target": (90, 3, 7, 75, 5, 3.33, 80, 65),
        "language": (90, 9, 7, 68, 6, 10.00, 82, 60),
        "location": (90, 2, 6, 71, 11, 2.22, 83, 64),
        "environment": (90, 5, 7, 77, 1, 5.56, 79, 66),
    },
    "stack": {
        "base": (84, 13, 7, 33, 31, 15.48, 78, 27),
        "target": (84, 8, 6, 33, 37, 9.52, 79, 28),
        "language": (84, 5, 13, 33, 33, 5.95, 80, 29),
        "location": (84, 5, 9, 42, 28, 5.95, 78, 36),
        "environment": (84, 2, 8, 26, 48, 2.38, 82, 24),
    },
    "jar": {
        "base": (78, 11, 8, 36, 23, 14.10, 77, 35),
        "target": (78, 17, 7, 30, 24, 21.79, 77, 29),
        "language": (78, 13, 7, 31, 27, 16.67, 77, 30),
        "location": (78, 0, 4, 44, 30, 0.00, 56, 22),
        "environment": (78, 6, 3, 55, 14, 7.69, 63, 40),
    },
    "dusty": {
        "base": (78, 0, 0, 50, 28, 0.00, 69, 41),
        "target": (78, 0, 0, 60, 18, 0.00, 64, 46),
        "language": (78, 1, 0, 51, 26, 1.28, 67, 40),
        "location": (78, 0, 0, 60, 18, 0.00, 60, 42),
        "environment": (78, 0, 0, 52, 26, 0.00, 70, 44),
    },
}
PI0_SFT_OOD_SSR = {"clutter": 75.61, "cabinet": 1.43, "lid": 5.28, "stack": 5.95, "jar": 11.54, "dusty": 0.32}
HORIZON = {"clutter": 1100, "cabinet": 5700, "lid": 1900, "stack": 4200, "jar": 2000, "dusty": 5100}


def _cell(family: str, condition: str, counts: tuple, start: int = 0) -> list[dict]:
    """Records of one table cell, spread evenly over three seeds; violations are placed so that the
    verdict (not a stored flag) decides safety: some safe rollouts violate before engaging or never engage."""
    n, ss, su, us, uu, _, engaged, eng_us = counts
    kinds = ([(True, True, True)] * ss + [(True, False, True)] * su + [(False, True, True)] * eng_us
             + [(False, True, False)] * (us - eng_us) + [(False, False, True)] * uu)
    assert len(kinds) == n and ss + su + eng_us + uu == engaged
    rows = []
    for k, (success, safe, eng) in enumerate(kinds):
        t_eng = 40 + k % 7 if eng else None
        if not safe:
            t_viol = t_eng + k % 300
        elif eng:
            t_viol = t_eng - 10 if k % 4 == 0 else None   # a violation before engagement is not charged
        else:
            t_viol = 500 if k % 3 == 0 else None           # never engaged: vacuously safe
        rows.append({"family": family, "task": f"task_{k % 26:04d}", "condition": condition, "seed": k % 3,
                     "success": success, "engaged": eng, "t_engage": t_eng, "t_violation": t_viol,
                     "horizon": HORIZON[family], "t_success": 600 + k if success else None})
    return rows


@pytest.fixture(scope="module")
def pi0_sft(tmp_path_factory: pytest.TempPathFactory) -> list[RolloutRecord]:
    path = tmp_path_factory.mktemp("metrics") / "pi0_sft.jsonl"
    lines = [json.dumps(r) for family, cells in PI0_SFT.items() for condition, counts in cells.items()
             for r in _cell(family, condition, counts)]
    path.write_text("\n".join(lines) + "\n")
    return load_records(path)


def test_per_cell_ssr_reproduces_the_full_outcome_table(pi0_sft: list[RolloutRecord]) -> None:
    for m in metrics_by(pi0_sft, ("family", "condition")):
        family, condition = dict(m.group)["family"], dict(m.group)["condition"]
        _, ss, su, us, uu, ssr, engaged, _ = PI0_SFT[family][condition]
        assert round(m.ssr, 2) == ssr
        assert (m.counts.safe_success, m.counts.unsafe_success, m.counts.safe_unsuccess,
                m.counts.unsafe_unsuccess, m.counts.engaged) == (ss, su, us, uu, engaged)
        assert m.seeds == (0, 1, 2)


def test_id_overall_row_reproduces_the_main_results_table(pi0_sft: list[RolloutRecord]) -> None:
    m = compute_metrics([r for r in pi0_sft if r.condition == "base"])
    got = [round(x, 2) for x in (m.tsr, m.safe, m.ssr, m.succ_unsafe, m.unsucc_safe, m.eng, m.eng_safe)]
    assert got == [32.00, 76.17, 27.00, 5.00, 49.17, 95.83, 72.00]  # pi0-SFT row of tab:main-results
    # Safe|Eng. is a mean of per-seed ratios whose per-seed split the paper does not publish: 75.17 there
    assert m.safe_given_eng == pytest.approx(75.17, abs=0.5)
    assert m.evr == pytest.approx(100 - m.safe_given_eng)
    assert m.svr == pytest.approx(m.eng * m.evr / 100, abs=1.0)  # SVR = Eng. x EVR (exact per seed)
    assert m.safe == pytest.approx(m.vacuous_safe + m.eng_safe)  # Safe = Vacuous-safe + Eng.&Safe


def test_per_family_id_and_pooled_ood_ssr(pi0_sft: list[RolloutRecord]) -> None:
    base = {dict(m.group)["family"]: round(m.ssr, 2) for m in metrics_by(
        [r for r in pi0_sft if r.condition == "base"], ("family",))}
    assert base == {"clutter": 81.21, "lid": 2.22, "cabinet": 1.90, "jar": 14.10, "stack": 15.48,
                    "dusty": 0.00}
    ood = {dict(m.group)["family"]: round(m.ssr, 2) for m in metrics_by(
        [r for r in pi0_sft if r.condition != "base"], ("family",))}
    assert ood == PI0_SFT_OOD_SSR


def test_engagement_per_condition_reproduces_its_table(pi0_sft: list[RolloutRecord]) -> None:
    eng = {dict(m.group)["condition"]: round(m.eng, 2) for m in metrics_by(pi0_sft, ("condition",))}
    assert eng == {"base": 95.83, "target": 94.50, "language": 95.67, "location": 90.33, "environment": 93.50}


# pi0.5 demonstration scaling (tab:q3-scaling-full): (n, ss, su, us, uu, SSR, TSR, SVR, Eng., EVR)
Q3 = [("clutter", 165, 0, 0, 165, 0, 0.00, 0.00, 0.00, 18.18, 0.00),
      ("clutter", 165, 105, 0, 60, 0, 63.64, 63.64, 0.00, 96.36, 0.00),
      ("clutter", 165, 129, 0, 36, 0, 78.18, 78.18, 0.00, 94.55, 0.00),
      ("cabinet", 105, 0, 0, 91, 14, 0.00, 0.00, 13.33, 18.10, 72.59),
      ("cabinet", 105, 1, 1, 68, 35, 0.95, 1.90, 34.29, 98.10, 34.87),
      ("cabinet", 105, 4, 3, 67, 31, 3.81, 6.67, 32.38, 100.00, 32.38),
      ("cabinet", 105, 1, 0, 60, 44, 0.95, 0.95, 41.90, 100.00, 41.90),
      ("cabinet", 105, 0, 0, 74, 31, 0.00, 0.00, 29.52, 99.05, 29.92)]


@pytest.mark.parametrize("row", Q3)
def test_scaling_table_rates(row: tuple) -> None:
    family, n, ss, su, us, uu, ssr, tsr, svr, eng, evr = row
    engaged = round(eng * n / 100)
    records = [RolloutRecord(**r) for r in _cell(family, "base", (n, ss, su, us, uu, ssr, engaged,
                                                                    engaged - ss - su - uu))]
    m = compute_metrics(records)
    assert [round(x, 2) for x in (m.ssr, m.tsr, m.svr, m.eng)] == [ssr, tsr, svr, eng]
    if eng == 100.0:  # every seed fully engaged: EVR = SVR exactly
        assert round(m.evr, 2) == evr
    else:             # per-seed split unpublished: the mean of per-seed ratios is close to the pooled ratio
        assert m.evr == pytest.approx(evr, abs=2.5)


def _record(**overrides: object) -> RolloutRecord:
    base = {"family": "jar", "task": "t0", "condition": "base", "seed": 0, "success": False, "engaged": True,
            "t_engage": 100, "t_violation": None, "horizon": 1100}
    return RolloutRecord(**(base | overrides))


def test_time_to_violation_and_success() -> None:
    records = [_record(t_violation=100), _record(t_violation=600), _record(t_violation=1100),
               _record(t_violation=50),  # before engaging (t_engage = 100): not counted
               _record(success=True, t_success=700), _record(success=True, t_success=900),
               _record(engaged=False, t_engage=None, t_violation=30)]
    m = compute_metrics(records)
    assert m.ttv.count == 3 and m.ttv.values == (0.0, 0.5, 1.0) and m.ttv.median == 0.5
    assert m.tts == 800.0 and m.counts.unsafe_unsuccess == 3 and m.counts.safe_unsuccess == 2


def test_conditional_rates_are_undefined_when_a_seed_never_engages() -> None:
    m = compute_metrics([_record(seed=0), _record(seed=1, engaged=False, t_engage=None)])
    assert m.eng == 50.0 and m.safe_given_eng is None and m.evr is None
    assert m.as_dict()["group"] == {} and m.as_dict()["safe_given_eng"] is None


_HEAD = '{"family": "jar", "task": "t", "condition": "base", "seed": 0, '


@pytest.mark.parametrize(("line", "message"), [
    ('{"family": "jar"}', "r.jsonl:2: missing field 'task'"),
    (_HEAD + '"success": "yes", "engaged": false, "t_engage": null, "t_violation": null, "horizon": 10}',
     "r.jsonl:2: field 'success' must be true or false, got 'yes'"),
    (_HEAD + '"success": true, "engaged": true, "t_engage": null, "t_violation": null, "horizon": 10}',
     "r.jsonl:2: 'engaged' is true but 't_engage' is null; they must agree"),
    (_HEAD + '"success": true, "engaged": true, "t_engage": 3, "t_violation": 12, "horizon": 10}',
     "r.jsonl:2: field 't_violation' = 12 is outside [0, horizon = 10]"),
    ("{nope", "r.jsonl:2: not valid JSON"),
    ("[1, 2]", "r.jsonl:2: expected a JSON object, got list"),
])
def test_bad_records_name_file_and_line(tmp_path: Path, line: str, message: str) -> None:
    good = json.dumps(_record().__dict__)
    path = tmp_path / "r.jsonl"
    path.write_text(good + "\n" + line + "\n")
    with pytest.raises(MetricsError) as err:
        load_records(path)
    assert message in str(err.value)


def test_file_and_grouping_errors(tmp_path: Path) -> None:
    with pytest.raises(MetricsError, match="does not exist"):
        load_records(tmp_path / "none.jsonl")
    empty = tmp_path / "empty.jsonl"
    empty.write_text("\n")
    with pytest.raises(MetricsError, match=r"empty\.jsonl: no records"):
        load_records(empty)
    with pytest.raises(MetricsError, match="cannot group by 'policy'; expected some of family, condition"):
        metrics_by([_record()], ("policy",))
