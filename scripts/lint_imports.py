"""Check the layers contract (pyproject.toml ``[tool.importlinter]``) and count module import cycles.

import-linter (grimp) reads a package from its folder, but ``mgdata.skeletons``, ``mgdata.teleop`` and
``mgdata.annotator`` live in top-level folders mapped into the package (``package-dir``). So the package is
first staged as it installs (its ``.py`` files, in a temporary folder), then ``lint-imports`` runs on it and
grimp's graph of it (every import statement, those inside functions and ``if TYPE_CHECKING`` included) is
searched for cycles between modules.

Usage: python scripts/lint_imports.py      (exit 0: contract kept and no cycles)
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MAPPED = {"skeletons": "skeletons", "teleop": "teleop", "annotator": "annotator"}


def stage(dst: Path) -> Path:
    """Copy the package's modules into ``dst/mgdata`` laid out as the wheel installs them."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(REPO / "mgdata", dst / "mgdata", ignore=ignore)
    for name, folder in MAPPED.items():
        shutil.copytree(REPO / folder, dst / "mgdata" / name, ignore=ignore)
    shutil.copy(REPO / "pyproject.toml", dst / "pyproject.toml")
    return dst


def module_cycles(root: Path, package: str = "mgdata") -> list[tuple[str, ...]]:
    """Cycles between modules of ``package`` (grimp's graph of it, staged at ``root``): for each import
    ``a -> b`` with a way back (grimp's ``find_shortest_chain(b, a)``), one cycle per set of modules."""
    sys.path.insert(0, str(root))
    try:
        import grimp

        graph = grimp.build_graph(package, cache_dir=None)
    finally:
        sys.path.remove(str(root))
    cycles: list[tuple[str, ...]] = []
    seen: set[frozenset[str]] = set()
    for module in sorted(graph.modules):
        for imported in sorted(graph.find_modules_directly_imported_by(module)):
            back = graph.find_shortest_chain(importer=imported, imported=module)
            if back is not None and frozenset(back) not in seen:
                seen.add(frozenset(back))
                cycles.append((module, *back))
    return cycles


def main() -> int:
    with tempfile.TemporaryDirectory(prefix="mgdata-layers-") as tmp:
        root = stage(Path(tmp))
        env = {**os.environ, "PYTHONPATH": str(root)}
        lint = subprocess.run([str(Path(sys.executable).with_name("lint-imports")), "--no-cache"],
                              cwd=root, env=env, text=True, capture_output=True)
        print(lint.stdout.strip().splitlines()[-1] if lint.returncode == 0 else lint.stdout + lint.stderr)
        cycles = module_cycles(root)
    for cycle in cycles:
        print("cycle: " + " -> ".join(cycle))
    print(f"module cycles: {len(cycles)}")
    return 0 if lint.returncode == 0 and not cycles else 1


if __name__ == "__main__":
    sys.exit(main())
