"""Annotator live-check benchmark (prints figures; targets from issue 13).

- **agreement** with ``mgdata grasps validate``: grasps the live check marks green (reachable and clear at
  every placement) should pass the sim check (target >= 95 %), grasps it marks red should fail it (target
  >= 95 %); amber ones are reported but not scored. The grasps are the geometric candidates of several
  models, most of them perturbed (position N(0, ``--pos-sigma``) per axis, rotation about a random axis by
  N(0, ``--rot-sigma``)), so both outcomes occur; seeded, so a run is repeatable;
- **live-check time** per pose (median, p95, max) and the object-scene build time.

Run: ``.venv/bin/python benchmarks/bench_annotate.py [--n 200 --per-model 20 --seed 0]``
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from mgdata.annotator.config import load_annotate_config
from mgdata.annotator.live import LiveChecker
from mgdata.annotator.objectscene import ObjectScene
from mgdata.annotator.placements import recipe_placements
from mgdata.grasps.candidates import candidates
from mgdata.grasps.check import check_grasp
from mgdata.grasps.config import load_grasp_config
from mgdata.grasps.db import Grasp, approach_hint
from mgdata.motion import Pose
from mgdata.sim.assets import get_model, model_names

FAMILY_OF = {"jar": "jar"}  # categories whose family recipe gives the placements; others use the default


def _perturb(g: Grasp, rng: np.random.Generator, pos_sigma: float, rot_sigma: float, k: int) -> Grasp:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = math.radians(rng.normal(0.0, rot_sigma))
    turn = Pose(np.zeros(3), np.array([math.cos(angle / 2), *(axis * math.sin(angle / 2))]))
    pose = Pose(np.asarray(g.pos) + rng.normal(0.0, pos_sigma, 3), np.asarray(g.quat))
    pose = Pose(pose.pos, (Pose(np.zeros(3), pose.quat) @ turn).quat)
    quat = tuple(float(v) for v in pose.quat)
    return Grasp(f"{g.id}_p{k}", tuple(float(v) for v in pose.pos), quat, approach_hint(quat), "generated")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=200, help="grasps in all")
    ap.add_argument("--per-model", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pos-sigma", type=float, default=0.012, help="m")
    ap.add_argument("--rot-sigma", type=float, default=15.0, help="deg")
    ap.add_argument("--unperturbed", type=float, default=0.3, help="fraction of grasps left as generated")
    args = ap.parse_args()

    settings, check_cfg = load_annotate_config(), load_grasp_config()
    live_cfg, cand_cfg = settings.live, check_cfg.candidates
    rng = np.random.default_rng(args.seed)
    pool = [m for c in ("jar", "cup", "bottle", "box", "mug") for m in model_names(c)]
    models = [m for m in rng.permutation(pool) if candidates(get_model(str(m)), cand_cfg)]
    rows, times, builds = [], [], []
    for key in models:
        if len(rows) >= args.n:
            break
        key = str(key)
        category = key.split("/", 1)[0]
        placements = recipe_placements(FAMILY_OF.get(category), category, live_cfg)
        t0 = time.perf_counter()
        obj = ObjectScene.build(key, placements[0], live_cfg)
        builds.append(time.perf_counter() - t0)
        checker = LiveChecker(obj, placements, live_cfg, check_cfg.check)
        cands = candidates(get_model(key), cand_cfg)
        for k in range(min(args.per_model, args.n - len(rows))):
            g = cands[int(rng.integers(len(cands)))]
            if rng.random() >= args.unperturbed:
                g = _perturb(g, rng, args.pos_sigma, args.rot_sigma, k)
            verdict = checker.check(Pose(np.asarray(g.pos), np.asarray(g.quat)), warm=False)
            assert verdict is not None
            times.append(verdict.seconds)
            status, detail = check_grasp(key, g, check_cfg.check)
            rows.append((key, g.id, verdict.level, status, detail))
            print(f"{len(rows):4d} {key:18s} {g.id:22s} live {verdict.level:5s} sim {status:7s} {detail}",
                  flush=True)

    def share(level: str, status: str) -> tuple[int, int]:
        marked = [r for r in rows if r[2] == level]
        return sum(r[3] == status for r in marked), len(marked)

    ok_g, n_g = share("green", "valid")
    ok_r, n_r = share("red", "invalid")
    n_a = sum(r[2] == "amber" for r in rows)
    valid_amber = sum(r[2] == "amber" and r[3] == "valid" for r in rows)
    t = np.array(times) * 1000
    print()
    n_valid = sum(r[3] == "valid" for r in rows)
    print(f"grasps: {len(rows)} over {len({r[0] for r in rows})} models; sim valid {n_valid}")
    print(f"green -> valid: {ok_g}/{n_g} = {100 * ok_g / max(n_g, 1):.1f} % (target >= 95 %)")
    print(f"red -> invalid: {ok_r}/{n_r} = {100 * ok_r / max(n_r, 1):.1f} % (target >= 95 %)")
    print(f"amber (not scored): {n_a}, of which sim valid {valid_amber}")
    print(f"live check per pose: median {np.median(t):.0f} ms, p95 {np.percentile(t, 95):.0f} ms, "
          f"max {t.max():.0f} ms; object scene build: median {1000 * np.median(builds):.0f} ms")


if __name__ == "__main__":
    main()
