"""Open-loop precision of a trained policy at the grasp: on the recorded states of demonstrations, how far the
policy's action chunk puts the hand from where the demonstration put it, in centimetres at the TCP.

For every episode of a state-view dataset (``mgdata export --format state``), the frames of the last
``--window`` control steps before the carry grasp closes (the gripper's first close, after its first open if
it starts closed; ``--phase goal``: before the demo ends, the placing and the hold at rest) are sent to the
checkpoint as ``mgdata eval --convention state`` would send them; the first ``--steps`` actions of each
predicted chunk are compared with the demonstration's next actions: joint error (rad) and the distance between
the TCPs those joint targets put the hand at (forward kinematics, MuJoCo).
Run it on the training demos and on demos of held-out layouts (``mgdata generate --tasks`` of tasks the policy
never saw): the first says how well the policy fits, the second how well it generalises, without the
compounding of a closed loop. The figures say whether the policy is precise enough for a grasp whose open
fingers clear the object by a centimetre or so.

The prediction runs in the LeRobot environment (``--lerobot-python``, torch + lerobot) and the kinematics in
mgdata's::

    LEROBOT_PYTHON=/work/lerobot-venv/bin/python .venv/bin/python benchmarks/learn_openloop.py \\
        --checkpoint /tmp/L/single60/train/checkpoints/last/pretrained_model \\
        --data /tmp/L/single60/data_state --data /tmp/L/heldout_state
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from bench_learn import carry_grasp_step

REPO = Path(__file__).resolve().parent.parent


def _frames(data: Path) -> dict[str, np.ndarray]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    cols = ["episode_index", "observation.state", "observation.environment_state", "action"]
    table = pa.concat_tables([pq.read_table(f, columns=cols) for f in sorted(data.glob("data/*/*.parquet"))])
    out = {"episode": table.column("episode_index").to_numpy()}
    for k in cols[1:]:
        out[k] = np.stack(table.column(k).to_numpy(zero_copy_only=False)).astype(np.float32)
    return out


def windows(episode: np.ndarray, action: np.ndarray, window: int, steps: int, phase: str) -> list[np.ndarray]:
    """Row indices, per episode, of the ``window`` steps before the carry grasp closes
    (:func:`bench_learn.carry_grasp_step`; ``phase`` "grasp") or before the demo ends (``"goal"``: the
    placing and the hold at rest), each with ``steps`` demonstrated actions after it."""
    out = []
    for e in np.unique(episode):
        rows = np.flatnonzero(episode == e)
        end = carry_grasp_step(action[rows, 7]) if phase == "grasp" else len(rows) - steps
        if end is not None:
            out.append(rows[max(0, end - window): min(end, len(rows) - steps)])
    return out


def predict(args: argparse.Namespace) -> None:
    """(LeRobot environment) the predicted chunks of the grasp windows' frames, saved to ``args.save``."""
    sys.path.insert(0, str(REPO))
    import torch

    from mgdata.evaluate.lerobot_policy import LeRobotPolicy

    torch.set_num_threads(1)
    policy = LeRobotPolicy(args.checkpoint)
    saved = {}
    for k, data in enumerate(args.data):
        f = _frames(data)
        rows = np.concatenate(windows(f["episode"], f["action"], args.window, args.steps, args.phase))
        chunks = [policy.infer({"observation.state": f["observation.state"][r],
                                "observation.environment_state": f["observation.environment_state"][r],
                                "task": ""})["actions"][: args.steps] for r in rows]
        demo = np.stack([f["action"][r: r + args.steps] for r in rows])
        ahead = np.stack([f["action"][np.clip(np.arange(r, r + 3 * args.steps), None,
                                              np.flatnonzero(f["episode"] == f["episode"][r])[-1])]
                          for r in rows])
        saved |= {f"pred{k}": np.stack(chunks), f"demo{k}": demo, f"ahead{k}": ahead,
                  f"episode{k}": f["episode"][rows]}
    np.savez(args.save, **saved)


def tcp_positions(q: np.ndarray) -> np.ndarray:
    """TCP positions (…, 3) of arm configurations (…, 7), robot base frame."""
    import mujoco

    from mgdata.sim import robot

    model = robot.load_panda_spec().compile()
    data = mujoco.MjData(model)
    adr, site = robot.arm_qpos_adr(model), model.site(robot.TCP_SITE).id
    flat = q.reshape(-1, 7)
    out = np.empty((len(flat), 3))
    for i, qi in enumerate(flat):
        data.qpos[adr] = qi
        mujoco.mj_kinematics(model, data)
        out[i] = data.site_xpos[site]
    return out.reshape(*q.shape[:-1], 3)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--checkpoint", type=Path, required=True)
    p.add_argument("--data", type=Path, action="append", required=True, help="state-view dataset (repeat)")
    p.add_argument("--window", type=int, default=40, help="control steps looked at")
    p.add_argument("--phase", choices=("grasp", "goal"), default="grasp",
                   help="the steps before the carry grasp closes, or the last steps of the demo")
    p.add_argument("--steps", type=int, default=10, help="actions compared per chunk (executed per query)")
    p.add_argument("--lerobot-python", default=os.environ.get("LEROBOT_PYTHON", sys.executable))
    p.add_argument("--predict", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--save", type=Path, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.predict:
        predict(args)
        return
    with tempfile.TemporaryDirectory() as tmp:
        save = Path(tmp) / "chunks.npz"
        cmd = [args.lerobot_python, __file__, "--predict", "--save", str(save), "--checkpoint",
               str(args.checkpoint), "--window", str(args.window), "--steps", str(args.steps),
               "--phase", args.phase]
        for d in args.data:
            cmd += ["--data", str(d)]
        subprocess.run(cmd, check=True, env={**os.environ, "HF_HUB_OFFLINE": "1", "OMP_NUM_THREADS": "1"})
        chunks = dict(np.load(save))
    report = {}
    for k, data in enumerate(args.data):
        pred, demo = chunks[f"pred{k}"], chunks[f"demo{k}"]
        joint = np.abs(pred[..., :7] - demo[..., :7]).mean(axis=(0, 1))
        at = tcp_positions(pred[..., :7])
        tcp = np.linalg.norm(at - tcp_positions(demo[..., :7]), axis=-1).mean(axis=1)
        # off the demonstrated path: the nearest of the demonstration's TCPs over three times the steps ahead
        # (what is left of the distance once timing along the path is forgiven)
        path = tcp_positions(chunks[f"ahead{k}"][..., :7])
        off_path = np.linalg.norm(at[:, :, None] - path[:, None], axis=-1)
        off_path = off_path.min(axis=2).mean(axis=1)
        grip = float((np.round(pred[..., 7]) == np.round(demo[..., 7])).mean())
        episodes = chunks[f"episode{k}"]
        per_episode = [float(tcp[episodes == e].mean()) for e in np.unique(episodes)]
        report[str(data)] = {
            "frames": len(pred), "episodes": len(per_episode),
            "joint_err_rad": [round(float(v), 3) for v in joint],
            "tcp_err_cm": {"median": round(100 * float(np.median(tcp)), 2),
                           "p90": round(100 * float(np.percentile(tcp, 90)), 2),
                           "worst_episode": round(100 * max(per_episode), 2)},
            "off_path_cm": {"median": round(100 * float(np.median(off_path)), 2),
                            "p90": round(100 * float(np.percentile(off_path, 90)), 2)},
            "gripper_agrees": round(grip, 3)}
        r = report[str(data)]
        t, o = r["tcp_err_cm"], r["off_path_cm"]
        where = "grasp closes" if args.phase == "grasp" else "demo ends"
        print(f"{data}: {r['episodes']} episodes, {r['frames']} frames in the {args.window} steps before the "
              f"{where}; TCP off the demonstration by {t['median']:.2f} cm median, {t['p90']:.2f} cm "
              f"p90 (worst episode {t['worst_episode']:.2f} cm), off its path {o['median']:.2f} cm median, "
              f"{o['p90']:.2f} cm p90; "
              f"joint error {' '.join(f'{v:.3f}' for v in joint)} rad; gripper agrees {100 * grip:.1f} %")
    print(json.dumps(report))


if __name__ == "__main__":
    main()
