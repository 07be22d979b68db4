"""The layers import downward only (pyproject.toml's import-linter contract) and no two modules import each
other, directly or through others, counting imports inside functions and under ``TYPE_CHECKING``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.helpers.repo import REPO


def test_layers_contract_and_no_module_cycles() -> None:
    run = subprocess.run([sys.executable, str(REPO / "scripts" / "lint_imports.py")], capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "Contracts: 1 kept, 0 broken." in run.stdout
    assert "module cycles: 0" in run.stdout


def test_the_cycle_count_sees_a_cycle(tmp_path: Path) -> None:
    sys.path.insert(0, str(REPO / "scripts"))
    try:
        import lint_imports
    finally:
        sys.path.remove(str(REPO / "scripts"))
    pkg = tmp_path / "cyclic_pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("def f():\n    from cyclic_pkg import b\n")
    (pkg / "b.py").write_text("import typing\nif typing.TYPE_CHECKING:\n    from cyclic_pkg import a\n")
    cycles = lint_imports.module_cycles(tmp_path, "cyclic_pkg")
    assert cycles == [("cyclic_pkg.a", "cyclic_pkg.b", "cyclic_pkg.a")]
