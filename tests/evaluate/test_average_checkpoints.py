"""Opt-in (`-m lerobot`): ``benchmarks/average_checkpoints.py`` writes the element-wise mean of the
checkpoints' weights, keeps the last one's config and processors, and refuses checkpoints of another model.
Needs the venv of ``scripts/check_lerobot_compat.sh`` (``LEROBOT_VENV``)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from mgdata.paths import project_root

from .test_lerobot_train import _venv_python

pytestmark = pytest.mark.lerobot

SCRIPT = project_root() / "benchmarks" / "average_checkpoints.py"

MAKE = """
import sys, torch
from pathlib import Path
from safetensors.torch import save_file
for k, scale in enumerate((1.0, 2.0, 4.5)):
    d = Path(sys.argv[1]) / f"c{k}"
    d.mkdir()
    g = torch.Generator().manual_seed(k)
    save_file({"w": torch.randn(3, 4, generator=g) * scale, "b": torch.full((4,), scale),
               "steps": torch.tensor([k], dtype=torch.int64)}, str(d / "model.safetensors"))
    (d / "config.json").write_text(f'{{"k": {k}}}')
"""

CHECK = """
import sys, torch
from pathlib import Path
from safetensors.torch import load_file
root = Path(sys.argv[1])
got = load_file(str(root / "avg" / "model.safetensors"))
ws = [load_file(str(root / f"c{k}" / "model.safetensors")) for k in range(3)]
want = (ws[0]["w"].double() + ws[1]["w"].double() + ws[2]["w"].double()) / 3
assert got["w"].dtype == torch.float32
assert torch.allclose(got["w"].double(), want, atol=1e-6), (got["w"], want)
assert torch.allclose(got["b"], torch.full((4,), 7.5 / 3))
assert got["steps"].tolist() == [2]  # integer buffers: the last checkpoint's
assert (root / "avg" / "config.json").read_text() == '{"k": 2}'
print("ok")
"""


def test_the_average_is_the_mean_of_the_weights(tmp_path: Path) -> None:
    python = _venv_python()
    subprocess.run([python, "-c", MAKE, str(tmp_path)], check=True)
    subprocess.run([python, str(SCRIPT), str(tmp_path / "avg"), *(str(tmp_path / f"c{k}") for k in range(3))],
                   check=True)
    out = subprocess.run([python, "-c", CHECK, str(tmp_path)], capture_output=True, text=True)
    assert out.stdout.strip() == "ok", out.stderr
    assert not (tmp_path / "avg.partial").exists()


def test_checkpoints_of_another_model_are_refused(tmp_path: Path) -> None:
    python = _venv_python()
    subprocess.run([python, "-c", MAKE, str(tmp_path)], check=True)
    other = tmp_path / "other"
    other.mkdir()
    subprocess.run([python, "-c", "import sys, torch; from safetensors.torch import save_file; "
                    "save_file({'w': torch.zeros(2)}, sys.argv[1])", str(other / "model.safetensors")],
                   check=True)
    run = subprocess.run([python, str(SCRIPT), str(tmp_path / "avg"), str(tmp_path / "c0"), str(other)],
                         capture_output=True, text=True)
    assert run.returncode != 0 and "other tensors" in run.stderr
    assert not (tmp_path / "avg").exists()
