"""The dataset card: ``README.md`` at a dataset's root, the page the Hugging Face Hub shows for it.

A card is rendered from what the dataset stores and nothing else: ``meta/info.json`` (totals, features and
the ``mgdata`` block: spec, gate, generator, recovery, attempts), the task strings and a tally of the
episodes' metadata (:class:`EpisodeTally`). No clock and no path go in, so the same dataset gives the same
bytes and ``mgdata validate`` checks a card by rendering it again. The writer puts the card into every commit
beside ``info.json`` (:class:`~mgdata.record.writer.DatasetWriter`: ``generate``, ``merge``, ``render``,
``validate --repair``, ``teleop``), ``export`` writes its view's own, and ``mgdata card DATASET``
(:func:`write_card`) rewrites it. It is not in ``info.json``'s checksums: it is derived data.

The YAML front matter is the Hub's, as LeRobot writes it (``license``, ``task_categories``, ``tags``,
``configs``; :mod:`mgdata.record.frontmatter` writes and reads it without a YAML library).

Example::

    text = card_of(DatasetReader(Path("datasets/jar")))     # what README.md must hold
    write_card(Path("datasets/jar"))                         # rewrite it (``mgdata card``)
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mgdata.atomic import write_text_atomic
from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.commit import WriterLock, recover
from mgdata.record.episode import EpisodeMeta
from mgdata.record.frontmatter import dump_front_matter
from mgdata.record.reader import DatasetReader

LICENSE = "apache-2.0"
"""pyproject.toml's ``Apache-2.0`` as a Hub license id (the Panda model in the scenes is Apache-2.0 too)."""
DATA_FILES = "data/*/*.parquet"  # LeRobot's glob: v3.0 data/chunk-*/file-*, v2.1 data/chunk-*/episode_*
MAX_PROMPTS = 10


@dataclass(frozen=True)
class EpisodeTally:
    """What the card says about the episodes, counted one episode at a time (:meth:`plus`: the writer adds
    each commit's episode, so a commit's card costs no more at episode 10,000 than at episode 1).

    Attributes:
        episodes, kept, unsafe (verdict ν false), unsuccessful: episode counts.
        families, conditions, sources: episodes per name. task_ids: the base tasks. versions: the episodes'
            ``software_version`` (the mgdata that recorded them).
    """

    episodes: int = 0
    kept: int = 0
    unsafe: int = 0
    unsuccessful: int = 0
    families: Mapping[str, int] = field(default_factory=dict)
    conditions: Mapping[str, int] = field(default_factory=dict)
    sources: Mapping[str, int] = field(default_factory=dict)
    task_ids: frozenset[int] = frozenset()
    versions: frozenset[str] = frozenset()

    def plus(self, meta: EpisodeMeta) -> EpisodeTally:
        """This tally with one more episode."""
        def bump(counts: Mapping[str, int], key: str) -> dict[str, int]:
            return {**counts, key: counts.get(key, 0) + 1}

        return EpisodeTally(
            self.episodes + 1, self.kept + bool(meta.kept), self.unsafe + (not meta.verdict),
            self.unsuccessful + (not meta.success), bump(self.families, meta.family),
            bump(self.conditions, meta.condition), bump(self.sources, meta.source),
            self.task_ids | {meta.task_id},
            self.versions | ({meta.software_version} if meta.software_version else set()))

    @classmethod
    def of(cls, metas: Iterable[EpisodeMeta]) -> EpisodeTally:
        """The tally of ``metas`` (equal to adding them one by one)."""
        metas = list(metas)
        return cls(len(metas), sum(bool(m.kept) for m in metas), sum(not m.verdict for m in metas),
                   sum(not m.success for m in metas), dict(Counter(m.family for m in metas)),
                   dict(Counter(m.condition for m in metas)), dict(Counter(m.source for m in metas)),
                   frozenset(m.task_id for m in metas),
                   frozenset(m.software_version for m in metas if m.software_version))


def card_of(reader: DatasetReader) -> str:
    """The card of the (v3.0) dataset ``reader`` reads, as it is now."""
    return render_card(reader.info, reader.tasks, reader_tally(reader))


def reader_tally(reader: DatasetReader) -> EpisodeTally:
    """The tally of every episode of ``reader``'s dataset (also an export's: every view keeps them all)."""
    return EpisodeTally.of(r.meta for r in reader.records())


def write_card(root: Path) -> Path:
    """(Re)write ``README.md`` of the mgdata v3.0 dataset at ``root`` atomically; returns its path.

    Takes the dataset's writer lock (refused while another process writes it) and finishes an interrupted
    commit first, as a writer's open does.
    """
    root = Path(root)
    if not (root / layout.INFO_PATH).exists():
        raise DatasetError(f"{root}: no dataset here ({layout.INFO_PATH} missing)")
    lock = WriterLock(root)
    try:
        recover(root)
        path = root / layout.CARD_PATH
        write_text_atomic(path, card_of(DatasetReader(root)))
    finally:
        lock.release()
    return path


# --- rendering ---------------------------------------------------------------------------------------------

def render_card(info: Mapping[str, Any], tasks: Sequence[str], tally: EpisodeTally) -> str:
    """The card (Markdown with YAML front matter) of a dataset with this ``info.json``, these task strings
    and these episodes."""
    sections = [_front_matter(info, tally), _intro(info, tally), _contents(info, tasks, tally),
                _prompts(info, tasks), _spec(info), _made(info, tally), _features(info), _load(info),
                _check(info), _license(info)]
    return "\n\n".join(s for s in sections if s) + "\n"


def _front_matter(info: Mapping[str, Any], tally: EpisodeTally) -> str:
    robot = str(info.get("robot_type") or "")
    tags = [t for t in dict.fromkeys(["LeRobot", "mgdata", *sorted(tally.families), robot, "mujoco",
                                      "simulation", "safety"]) if t]
    return dump_front_matter({"license": LICENSE, "task_categories": ["robotics"], "tags": tags,
                              "configs": [{"config_name": "default", "data_files": DATA_FILES}]})


def _v21(info: Mapping[str, Any]) -> bool:
    return info.get("codebase_version") != layout.CODEBASE_VERSION


def _cameras(info: Mapping[str, Any]) -> list[tuple[str, dict]]:
    return [(k, f) for k, f in info["features"].items() if f.get("dtype") == "video"]


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _counts(counts: Mapping[str, int]) -> str:
    return ", ".join(f"`{k}` {v}" for k, v in sorted(counts.items())) or "none"


def _ids(ids: Iterable[int]) -> str:
    """``{0, 1, 2, 5}`` → ``"0–2, 5"``."""
    runs: list[list[int]] = []
    for i in sorted(ids):
        if runs and i == runs[-1][1] + 1:
            runs[-1][1] = i
        else:
            runs.append([i, i])
    return ", ".join(str(a) if a == b else f"{a}–{b}" for a, b in runs)


def _intro(info: Mapping[str, Any], tally: EpisodeTally) -> str:
    families = ", ".join(sorted(tally.families)) or "mgdata"
    made = f" by mgdata {', '.join(sorted(tally.versions))}" if tally.versions else " by mgdata"
    if any(k in info["features"] for k in layout.SAFETY_VECTORS):
        record = ("a safety record on every frame: the truth of each proposition of the safety "
                  "specification, each constraint's monitor state and violation flag")
    else:  # the state view drops the per-frame vectors
        record = ("per-frame engagement and success flags and each episode's safety verdict (the per-frame "
                  "labels, monitor states and violation flags are in the dataset it was exported from)")
    return (f"# {families}: safety-annotated robot demonstrations\n\n"
            f"Robot-manipulation episodes in MuJoCo simulation (robot `{info.get('robot_type')}`) with "
            f"{record}. Written{made} in the LeRobot {info.get('codebase_version')} format.")


def _contents(info: Mapping[str, Any], tasks: Sequence[str], tally: EpisodeTally) -> str:
    mg = info.get("mgdata") or {}
    fps, frames = int(info["fps"]), int(info["total_frames"])
    seconds = frames / fps if fps else 0.0
    duration = f"{seconds:.1f} s" if seconds < 120 else f"{seconds / 60:.1f} min"
    cams = _cameras(info)
    if cams:
        h, w = cams[0][1]["shape"][:2]
        codec = (cams[0][1].get("info") or {}).get("video.codec", "video")
        cameras = f"{', '.join(layout.camera_name(k) for k, _ in cams)} ({h}×{w} RGB, {codec})"
    else:
        cameras = "none (state only)"
    lines = [
        f"- **Families:** {_counts(tally.families)}",
        f"- **Episodes:** {tally.episodes} ({frames} frames at {fps} fps, {duration})",
        f"- **Tasks:** {_count(len(tally.task_ids), 'base task')} (ids {_ids(tally.task_ids) or 'none'}), "
        f"{_count(len(tasks), 'prompt')}",
        f"- **Cameras:** {cameras}",
        f"- **Kept:** {_kept(mg, tally)}",
        f"- **Negatives:** {_negatives(mg, tally)}",
        f"- **Conditions:** {_counts(tally.conditions)}",
        f"- **Recovery:** {_recovery(mg)}",
        f"- **Sources:** {_counts(tally.sources)}",
    ]
    return "## Contents\n\n" + "\n".join(lines)


def _kept(mg: Mapping[str, Any], tally: EpisodeTally) -> str:
    text = f"{tally.kept} of {_count(tally.episodes, 'episode')} passed the gate"
    if mg.get("kept_only"):
        text += " (the dataset holds kept demonstrations only)"
    attempts = mg.get("attempts")
    if attempts:
        text += f"; {_count(attempts, 'attempt')} made them (yield {tally.kept / attempts:.1%})"
    return text


def _negatives(mg: Mapping[str, Any], tally: EpisodeTally) -> str:
    negatives = tally.episodes - tally.kept
    if negatives:
        return (f"{negatives} (`mgdata/kept` false: failed or unsafe episodes with their labels and failure "
                f"stage), of which {tally.unsafe} unsafe (verdict ν = 0) and {tally.unsuccessful} without "
                "success")
    if mg.get("kept_only"):
        return ("none (`mgdata generate --keep-failed` writes the failed and unsafe attempts to "
                "`<out>_failed`)")
    return "none"


def _recovery(mg: Mapping[str, Any]) -> str:
    rec = mg.get("recovery")
    if not rec:
        return "none (`action` is what the controller ran)"
    return (f"`{rec.get('mode')}`, amplitude {rec.get('amplitude')} rad, pushes of {rec.get('push_steps')} "
            f"steps: `action` is the plan's target, `{layout.EXECUTED_ACTION}` what the controller ran")


def _prompts(info: Mapping[str, Any], tasks: Sequence[str]) -> str:
    where = "meta/tasks.jsonl" if _v21(info) else layout.TASKS_PATH
    shown = [f"{i + 1}. {' '.join(t.split())}" for i, t in enumerate(tasks[:MAX_PROMPTS])]
    more = [f"\n\n… and {len(tasks) - MAX_PROMPTS} more in `{where}`."] if len(tasks) > MAX_PROMPTS else []
    return (f"## Prompts\n\nThe task strings (`{where}`, by `task_index`):\n\n" + "\n".join(shown)
            + "".join(more)) if tasks else ""


def _spec(info: Mapping[str, Any]) -> str:
    spec = (info.get("mgdata") or {}).get("spec")
    if not spec:
        return "## Safety specification\n\nNone stored (the writer was given none)."
    props = ", ".join(f"`{name}` ({p.get('evaluator')})" for name, p in spec["propositions"].items())
    constraints = "\n".join(f"- `{c['id']}`: `{c['formula']}`" + (f" — {c['description']}"
                                                                   if c.get("description") else "")
                            for c in spec["constraints"])
    labels = f" (`{layout.LABELS}`, in this order)" if layout.LABELS in info["features"] else ""
    monitor = f" (`{layout.DFA_STATE}` and `{layout.VIOLATED}`, in this order)" \
        if layout.DFA_STATE in info["features"] else ""
    return (f"## Safety specification `{spec['name']}`\n\nPropositions{labels}: {props}.\n\n"
            f"Constraints, LTL_f formulas over them{monitor}:\n\n{constraints}")


def _made(info: Mapping[str, Any], tally: EpisodeTally) -> str:
    mg = info.get("mgdata") or {}
    parts = []
    gen = mg.get("generator")
    if gen:
        command = f"mgdata generate --family {gen.get('family')} --seed {gen.get('seed')}"
        if len(tally.conditions) > 1:
            command += " --condition all"
        elif tally.conditions and "base" not in tally.conditions:
            command += f" --condition {next(iter(tally.conditions))}"
        if mg.get("recovery"):
            command += f" --recovery {mg['recovery'].get('mode')}"
        what = "Generated by" if mg.get("kept_only") else "The labelled negatives (`--keep-failed`) of"
        parts.append(f"{what} `{command}` (inputs digest `{gen.get('inputs_digest')}`: the recipe, spec, "
                     "simulator and motion settings and grasp database; the same inputs and seed give the "
                     "same bytes).")
    gate = _gate(mg)
    if gate:
        parts.append(gate)
    rendered = mg.get("rendered_from")
    if rendered:
        size = rendered.get("size")
        parts.append(f"Re-rendered by `mgdata render` from the stored physics states (cameras "
                     f"{', '.join(rendered.get('cameras') or [])}, {size}×{size}, {rendered.get('codec')}); "
                     "every column but the pictures is its source's.")
    if mg.get("exported_as"):
        copied = " (video packets copied: the frames are the source's, bit for bit)" if _cameras(info) else ""
        parts.append(f"Exported by `mgdata export --format {mg['exported_as']}`{copied}.")
    if not gen:
        parts.append(f"No generator run is recorded in `meta/info.json`; the episodes' sources: "
                     f"{_counts(tally.sources)}.")
    return "## How it was made\n\n" + "\n\n".join(parts)


def _gate(mg: Mapping[str, Any]) -> str:
    hold, physics = mg.get("hold_steps"), mg.get("physics_gate")
    if hold is None and not physics:
        return ""
    held = f"on its last {hold} frames" if hold is not None else "on its last frame"
    text = f"An episode is kept when it succeeded (the goal held {held}"
    if physics:
        subjects = ", ".join(f"`{s}`" for s in physics.get("rest_subjects") or [])
        text += (f", at rest: {subjects} below {physics.get('rest_linear_speed')} m/s and "
                 f"{physics.get('rest_angular_speed')} rad/s at every physics substep")
    text += ") and violated no constraint on any frame"
    if physics:
        text += f", with no contact deeper than {float(physics.get('max_penetration', 0.0)) * 1000:g} mm"
    return text + "."


_STATE = ("7 measured arm joint angles (rad) + gripper opening (m; while grasping, the held object's "
          "width)")
_ACTION = ("7 commanded joint targets (rad) + `gripper_command`: 1 close, 0 open, a binary command, not the "
           "state's metres (the simulated gripper closes under force control until contact)")
_MEANING = {
    layout.STATE: _STATE, "state": _STATE, layout.ACTION: _ACTION, "actions": _ACTION,
    "observation.environment_state": "each task object's pose (robot base frame) and joints, and the goal; "
                                     f"derived from `{layout.PHYSICS_STATE}`, names in `meta/info.json`",
    layout.LABELS: "the truth of each proposition (in the spec's order)",
    layout.DFA_STATE: "each constraint's monitor (DFA) state after this frame",
    layout.VIOLATED: "each constraint violated at or before this frame (latched)",
    layout.ENGAGED: "first engagement with the task happened at or before this frame (latched)",
    layout.SUCCESS: "the family's success predicate holds at this frame",
    layout.PHYSICS_STATE: "the MuJoCo state this frame was observed in (`mj_getState`, spec in "
                          "`meta/info.json`): with the scene in `meta/scenes/` it restores the frame exactly",
    layout.EXECUTED_ACTION: "the command the controller ran: `action` plus the recovery perturbation",
    "timestamp": "`frame_index / fps` (s)", "frame_index": "frame within its episode",
    "episode_index": "episode", "index": "frame within the dataset",
    "task_index": "the prompt (row of the tasks table)",
}


def _features(info: Mapping[str, Any]) -> str:
    rows = ["| feature | dtype | shape | meaning |", "|---|---|---|---|"]
    for key, ft in info["features"].items():
        shape = [int(n) for n in ft.get("shape") or []]
        text = f"({', '.join(map(str, shape))}{',' if len(shape) == 1 else ''})"
        if ft.get("dtype") == "video":
            meaning = f"camera `{layout.camera_name(key)}`: RGB video"
        else:
            meaning = _MEANING.get(key, "")
        rows.append(f"| `{key}` | {ft.get('dtype')} | {text} | {meaning} |")
    where = "`meta/mgdata_episodes.jsonl`" if _v21(info) else "the `mgdata/…` columns of `meta/episodes/`"
    return ("## Features\n\n" + "\n".join(rows) + "\n\nPer-episode metadata (family, task id, seed, "
            "success, verdict ν, kept, engagement and first-violation steps, grasp, variation draws, deepest "
            f"contact): {where}.")


def _load(info: Mapping[str, Any]) -> str:
    if _v21(info):
        return ("## Load it\n\nA LeRobot v2.1 folder (one parquet and one mp4 per episode), as openpi (pi0) "
                "and GR00T read it. LeRobot 0.4 reads v3.0: convert this folder in place with\n"
                "`python -m lerobot.datasets.v30.convert_dataset_v21_to_v30 --repo-id=HF_USER/DATASET "
                "--root=path/to/DATASET --push-to-hub=false`.")
    backend = ', video_backend="pyav"' if _cameras(info) else ""
    return ("## Load it\n\n```python\nfrom lerobot.datasets.lerobot_dataset import LeRobotDataset\n\n"
            f'ds = LeRobotDataset("HF_USER/DATASET", root="path/to/DATASET"{backend})\n```\n\n'
            "`root` is this folder; without it LeRobot downloads `HF_USER/DATASET` from the Hub.")


def _check(info: Mapping[str, Any]) -> str:
    if _v21(info):
        return ("## Check it\n\n`mgdata validate` reads LeRobot v3.0: validate the dataset this one was "
                "exported from.")
    gate = (info.get("mgdata") or {}).get("physics_gate") and layout.PHYSICS_STATE in info["features"]
    physics = " (its physical bounds from the stored physics states)" if gate else ""
    return ("## Check it\n\n`mgdata validate path/to/DATASET` checks structure, counts, statistics and "
            f"checksums, re-runs the safety monitor from the stored labels, audits the gate's promises"
            f"{physics} and checks this card (`mgdata card path/to/DATASET` rewrites it).")


def _license(info: Mapping[str, Any]) -> str:
    panda = (" The robot model is MuJoCo Menagerie's Franka Emika Panda (Apache-2.0)."
             if info.get("robot_type") == "franka_panda" else "")
    return f"## License\n\nApache-2.0, as mgdata.{panda}"
