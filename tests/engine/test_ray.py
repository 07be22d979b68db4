"""The Ray backend (``--ray``): a local Ray instance (one CPU per actor, a bounded object store, no
dashboard) writes the dataset a ``--workers 1`` run writes, byte for byte; a node whose fingerprint differs
from the main process's is refused."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mgdata.cpu import RESULT_FLAGS
from mgdata.errors import WorkerError
from mgdata.generate.fingerprint import local_fingerprint
from mgdata.generate.run import GenerateJob, generate
from tests.helpers.generate import low_yield_recipe
from tests.helpers.record import dataset_files

ray = pytest.importorskip("ray")
MGDATA = str(Path(sys.executable).parent / "mgdata")


def test_the_fingerprint_holds_what_changes_results() -> None:
    """Read /proc/cpuinfo here, independently: the fingerprint lists exactly the result-changing flags the
    CPU has, and a node with another version or other flags is told what differs."""
    flags = set()
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("flags"):
            flags = set(line.split(":", 1)[1].split())
            break
    mine = local_fingerprint("inputs")
    assert set(mine.cpu_flags) == {f for f in RESULT_FLAGS if f in flags}
    assert "llvmpipe" in mine.gl_renderer or mine.gl_renderer
    other = mine.__class__(**{**mine.__dict__, "mujoco": "0.0.1", "cpu_flags": ("sse4_1",), "host": "b"})
    problems = mine.differences(other)
    assert [p.split(":")[0] for p in problems] == ["mujoco", "cpu_flags"]
    assert mine.differences(mine.__class__(**{**mine.__dict__, "host": "elsewhere"})) == []


@pytest.mark.slow  # ~85 s on the loaded 2-core machine: Ray's start-up (~15 s) and two actors' first attempts
def test_a_ray_run_writes_the_bytes_of_one_worker(tmp_path: Path) -> None:
    recipe = low_yield_recipe(tmp_path)
    common = {"family": "jar", "n": 2, "tasks": (0, 1), "recipe": recipe, "max_attempts": 4}
    args = ["--n", "2", "--tasks", "0-1", "--recipe", str(recipe), "--max-attempts", "4", "--workers", "2"]
    proc = subprocess.run([MGDATA, "generate", *args, "--out", str(tmp_path / "ray"), "--ray"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    one = generate(GenerateJob(out=tmp_path / "one", workers=1, **common))
    assert one.kept == 2
    assert dataset_files(tmp_path / "ray") == dataset_files(tmp_path / "one")
    assert not list(Path("/tmp").glob("mgdata-ray-*")), "actors left staging folders behind"


def test_a_node_that_renders_differently_is_refused(tmp_path: Path) -> None:
    """llvmpipe limited to 128-bit vectors (another rasteriser code path, other pixels): the actors' GL
    renderer differs from this process's and the run stops before any attempt."""
    ray.init(num_cpus=1, object_store_memory=80 * 2**20, include_dashboard=False, log_to_driver=False,
             runtime_env={"env_vars": {"LP_NATIVE_VECTOR_WIDTH": "128", "LP_NUM_THREADS": "1"}})
    try:
        with pytest.raises(WorkerError, match=r"gl_renderer: .*256 bits.* vs .*128 bits"):
            generate(GenerateJob(family="jar", n=1, tasks=(0,), out=tmp_path / "ds", workers=1, ray="local",
                                 recipe=low_yield_recipe(tmp_path)))
    finally:
        ray.shutdown()
    assert not (tmp_path / "ds" / "data").exists()


def test_ray_takes_an_optional_address() -> None:
    from mgdata.cli import fill_optional_values

    assert fill_optional_values(["generate", "--ray"]) == ["generate", "--ray", "local"]
    assert fill_optional_values(["generate", "--ray", "--workers", "2"]) == \
        ["generate", "--ray", "local", "--workers", "2"]
    assert fill_optional_values(["generate", "--ray", "head:6379", "--n", "4"]) == \
        ["generate", "--ray", "head:6379", "--n", "4"]
