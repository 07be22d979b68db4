"""Rewrite imports from the pre-issue-23 layout to the one-package layout (idempotent).

Usage: python scripts/arch_renames.py FILE...   (rewrites in place; run it on code written against the old
layout, e.g. a branch that forked before the move; never on this file).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

MODULES = {
    "mgdata.engine.skeleton": "mgdata.skeleton.skeleton",
    "mgdata.engine.context": "mgdata.skeleton.context",
    "mgdata.engine.segment": "mgdata.skeleton.segment",
    "mgdata.engine.pick_and_carry": "mgdata.skeleton.pick_and_carry",
    "mgdata.engine.variation": "mgdata.skeleton.variation",
    "mgdata.engine.runner": "mgdata.episode.runner",
    "mgdata.engine.gate": "mgdata.episode.gate",
    "mgdata.engine.success": "mgdata.episode.success",
    "mgdata.engine.timing": "mgdata.episode.timing",
    "mgdata.engine.deferred": "mgdata.episode.deferred",
    "mgdata.engine.generate": "mgdata.generate.run",
    "mgdata.engine.workers": "mgdata.generate.workers",
    "mgdata.engine.raypool": "mgdata.generate.raypool",
    "mgdata.engine.resume": "mgdata.generate.resume",
    "mgdata.engine.merge": "mgdata.generate.merge",
    "mgdata.engine.summary": "mgdata.generate.summary",
    "mgdata.engine.suite": "mgdata.generate.suite",
    "mgdata.engine.task_report": "mgdata.generate.task_report",
    "mgdata.engine.fingerprint": "mgdata.generate.fingerprint",
    "mgdata.engine.commands": "mgdata.generate.commands",
    "mgdata.engine.preview": "mgdata.generate.preview",
    "mgdata.engine.scenarios": "mgdata.scenarios.store",
    "mgdata.engine.chunkstore": "mgdata.scenarios.chunkstore",
    "mgdata.engine.scenario_commands": "mgdata.scenarios.commands",
    "mgdata.engine.pool_worker": "mgdata.pool_worker",
    "mgdata.annotate": "mgdata.annotator",
    "mgdata.tasks.taskspec": "mgdata.sim.taskspec",
}
FROM_ENGINE = {  # from mgdata.engine import X
    "segment": "mgdata.skeleton", "context": "mgdata.skeleton", "chunkstore": "mgdata.scenarios",
    "gate": "mgdata.episode", "variation": "mgdata.skeleton",
}
NAMES = {  # names that moved out of a module: (old module, name) -> new module
    ("mgdata.sim.world", "Physics"): "mgdata.sim.physics_config",
    ("mgdata.engine.init_gate", "Infeasible"): "mgdata.skeleton.skeleton",
    ("mgdata.engine.guarded", "Guard"): "mgdata.skeleton.guard",
    ("mgdata.engine.guarded", "Until"): "mgdata.skeleton.guard",
    ("mgdata.engine.guarded", "touch"): "mgdata.skeleton.guard",
    ("mgdata.engine.guarded", "force"): "mgdata.skeleton.guard",
    ("mgdata.generate.run", "inputs_digest"): "mgdata.engine.inputs",
    ("mgdata.scenarios.store", "attempt_condition"): "mgdata.scenarios.conditions",
    ("mgdata.scenarios.store", "variant"): "mgdata.scenarios.conditions",
    ("mgdata.record.views", "export_dataset"): "mgdata.record.export",
}
"""Names that moved out of a module: an import of that name alone is rewritten; a mixed import is yours."""
TOP = ("skeletons", "teleop")


def rewrite(text: str) -> str:
    for old in sorted(MODULES, key=len, reverse=True):
        text = re.sub(rf"(?<![\w.]){re.escape(old)}(?![\w])", MODULES[old], text)
    for name, pkg in FROM_ENGINE.items():
        text = re.sub(rf"from mgdata\.engine import {name}\b", f"from {pkg} import {name}", text)
    for top in TOP:
        text = re.sub(rf"^(\s*)(from|import) {top}(?=[\s.])", rf"\1\2 mgdata.{top}", text, flags=re.M)
        text = re.sub(rf"([\"']){top}\.(?!toml)(?=[a-z_]+[\"'.{{])", rf"\1mgdata.{top}.", text)
    for (module, name), new in NAMES.items():
        text = re.sub(rf"^(\s*)from {re.escape(module)} import {name}$", rf"\1from {new} import {name}", text,
                      flags=re.M)
    return text


def main(paths: list[str]) -> None:
    for p in paths:
        path = Path(p)
        if path.resolve() == Path(__file__).resolve():
            continue
        old = path.read_text()
        new = rewrite(old)
        if new != old:
            path.write_text(new)
            print(f"rewrote {path}")


if __name__ == "__main__":
    main(sys.argv[1:])
