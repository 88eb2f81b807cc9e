"""docs/python.md runs: its Python blocks in order in one namespace, then its `spherejam` shell lines, in an empty
folder (a worked example that stopped working would fail here)."""

import re
import shlex
from pathlib import Path

from spherejam.cli import main

DOC = Path(__file__).resolve().parents[1] / "docs" / "python.md"


def blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", DOC.read_text(), flags=re.M | re.S)


def test_python_md_worked_example_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    python = blocks("python")
    assert len(python) >= 4 and "spherejam.jam(" in python[0]
    namespace: dict = {}
    for code in python:
        exec(compile(code, str(DOC), "exec"), namespace)  # noqa: S102 - the page's own example
    assert "phi_J = 0." in capsys.readouterr().out
    commands = [line.split("#")[0].strip() for block in blocks("bash") for line in block.splitlines()]
    commands = [c for c in commands if c.startswith("spherejam ")]
    assert commands
    for command in commands:
        assert main(shlex.split(command)[1:]) == 0, command
    assert Path("jammed.html").stat().st_size > 0
