"""The README's exit-status paragraph, for every command: a usage error (unknown option, missing option,
extra argument, a value of the wrong type) is one literal ``error:`` line naming the command, exit status 2,
no traceback and no framed panel. Most commands run in this process through ``mgdata.cli.main`` (the real
entry point); the two the issue names also run as real ``mgdata`` processes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import typer

from mgdata import cli

MGDATA = str(Path(sys.executable).parent / "mgdata")


def leaf_commands() -> list[tuple[str, ...]]:
    """Every command and command group of the app (``("generate",)``, ``("scenarios",)``,
    ``("scenarios", "build")`` …)."""
    cli._register_all()
    root = typer.main.get_command(cli.app)
    found: list[tuple[str, ...]] = []

    def walk(cmd: object, path: tuple[str, ...]) -> None:
        if path:
            found.append(path)
        for name, sub in getattr(cmd, "commands", {}).items():
            walk(sub, (*path, name))

    walk(root, ())
    return found


def run_main(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture, *argv: str) -> tuple[int, str,
                                                                                                   str]:
    monkeypatch.setattr(sys, "argv", ["mgdata", *argv])
    with pytest.raises(SystemExit) as exc:
        cli.main()
    out = capsys.readouterr()
    return int(exc.value.code or 0), out.out, out.err


def assert_one_error(code: int, out: str, err: str, *fragments: str) -> None:
    assert code == 2, out + err
    assert "Traceback" not in out + err and "╭" not in out + err and "Usage:" not in out + err, out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: mgdata "), err
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def test_every_command_is_listed() -> None:
    names = {" ".join(p) for p in leaf_commands()}
    assert {"generate", "merge", "render", "info", "validate", "eval", "serve random", "scenarios build",
            "scenarios verify", "annotate", "teleop"} <= names, names


@pytest.mark.parametrize("command", leaf_commands(), ids=" ".join)
def test_an_unknown_option_is_one_error_line(command: tuple[str, ...], monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture) -> None:
    code, out, err = run_main(monkeypatch, capsys, *command, "--no-such-option")
    assert_one_error(code, out, err, "mgdata " + " ".join(command), "--no-such-option")


@pytest.mark.parametrize("argv,fragments", [
    (("merge", "OUT", "SHARD"), ("mgdata merge", "Missing option '--out'")),
    (("scenarios", "verify", "PATH"), ("mgdata scenarios verify", "unexpected extra argument", "PATH")),
    (("generate", "--n", "many"), ("mgdata generate", "--n", "valid integer")),
    (("render", "ds"), ("mgdata render", "Missing option '--out'")),
    (("info",), ("mgdata info", "Missing argument 'dataset'")),
    (("eval", "--workers", "x"), ("mgdata eval", "--workers")),
    (("serve", "random", "--port", "p"), ("mgdata serve random", "--port")),
    (("no-such-command",), ("mgdata", "No such command 'no-such-command'")),
])
def test_usage_errors_are_one_line(argv: tuple[str, ...], fragments: tuple[str, ...],
                                   monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture) -> None:
    code, _out, err = run_main(monkeypatch, capsys, *argv)
    assert code == 2 and "Traceback" not in err and "╭" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: mgdata"), err
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


@pytest.mark.parametrize("argv,fragment", [
    (("merge", "OUT", "SHARD"), "error: mgdata merge: Missing option '--out'."),
    (("scenarios", "verify", "PATH"),
     "error: mgdata scenarios verify: Got unexpected extra argument(s) (PATH)"),
])
def test_the_issue_s_examples_through_the_real_command(argv: tuple[str, ...], fragment: str) -> None:
    proc = subprocess.run([MGDATA, *argv], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip() == fragment, proc.stderr
    assert proc.stdout == ""


def test_help_and_version_still_exit_0(monkeypatch: pytest.MonkeyPatch,
                                       capsys: pytest.CaptureFixture) -> None:
    code, out, _ = run_main(monkeypatch, capsys, "merge", "--help")
    assert code == 0 and "--out" in out
    code, out, _ = run_main(monkeypatch, capsys, "--version")
    assert code == 0 and out.startswith("mgdata ")


def test_a_user_error_after_parsing_is_still_one_line(monkeypatch: pytest.MonkeyPatch,
                                                      capsys: pytest.CaptureFixture, tmp_path: Path) -> None:
    code, _out, err = run_main(monkeypatch, capsys, "info", str(tmp_path / "absent"))
    assert code == 2 and err.startswith("error: ") and len(err.strip().splitlines()) == 1, err
