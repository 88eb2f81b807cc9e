"""The live progress line: shown on a (pseudo-)terminal, absent without one (log lines instead), silenced by -q."""

from __future__ import annotations

import fcntl
import os
import pty
import select
import struct
import subprocess
import sys
import termios

import pytest

from spherejam.cli import main

CLI = [sys.executable, "-m", "spherejam.cli"]


def _env():
    env = {k: v for k, v in os.environ.items() if k not in ("FORCE_COLOR", "NO_COLOR", "TTY_COMPATIBLE", "COLUMNS")}
    env["TERM"] = "xterm"
    return env


def run_on_terminal(args, cwd):
    """Run the CLI with stderr on a pseudo-terminal 200 columns wide; return (code, stdout, terminal output)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 50, 200, 0, 0))
    proc = subprocess.Popen([*CLI, *args], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=slave,
                            cwd=cwd, env=_env())
    os.close(slave)
    chunks = []
    while True:
        ready, _, _ = select.select([master], [], [], 0.2)
        if ready:
            try:
                data = os.read(master, 65536)
            except OSError:  # the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        elif proc.poll() is not None:
            break
    stdout = proc.stdout.read().decode()
    proc.wait(timeout=60)
    os.close(master)
    return proc.returncode, stdout, b"".join(chunks).decode(errors="replace")


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("progress")
    assert main(["seed", "--n", "100", "--seed", "4", "-o", str(d / "start.h5")]) == 0
    return d


LIVE = [
    ("ls", ["ls", "start.h5", "--rate", "0.1", "-o", "ls.h5"], ["log p/log p_max", "γ 0.1", "collisions/s", "φ"]),
    ("mls", ["mls", "ls.h5", "--final-rate", "0.1", "-o", "mls.h5"],
     ["stage", "stages left 0", "γ", "log p/log p_max", "collisions/s", " p "]),
    ("fb", ["fb", "start.h5", "--rate", "0.01", "-o", "fb.h5"], ["φ_in/φ_out", "iteration", "iterations/s"]),
    ("calippso", ["calippso", "mls.h5", "-o", "lp.h5"], ["LP ", "√Γ-1", "LP time"]),
]


@pytest.mark.parametrize("name, args, needles", LIVE, ids=[c[0] for c in LIVE])
def test_live_line_on_a_terminal(work, name, args, needles):
    interval = {"ls": ["--progress-interval", "0"], "mls": ["--progress-interval", "0"],
                "fb": ["--progress-interval", "0.001"]}.get(name, [])
    code, stdout, term = run_on_terminal([*args, *interval], work)
    assert code == 0, term[-2000:]
    assert f"{args[-1]}:" in stdout  # the result line stays on stdout
    assert "\x1b[" in term  # the line is redrawn in place (cursor control)
    for needle in needles:
        assert needle in term, (needle, term[-1500:])
    if name in ("ls", "mls"):  # the periodic log lines (one per window at interval 0) make way for the live line
        assert "window 1:" not in term
        assert "done:" in term  # the final summary line is still logged


def test_log_lines_without_a_terminal(work):
    r = subprocess.run([*CLI, "mls", "ls.h5", "--final-rate", "0.1", "-o", "mls2.h5", "--progress-interval", "0"],
                       cwd=work, capture_output=True, text=True, env=_env())
    assert r.returncode == 0, r.stderr
    assert "window 1:" in r.stderr and "done:" in r.stderr  # today's periodic lines, as in Snakemake/SLURM logs
    assert "\x1b[" not in r.stderr and "stages left" not in r.stderr


def test_quiet_silences_both(work):
    code, stdout, term = run_on_terminal(
        ["fb", "start.h5", "--rate", "0.01", "-o", "fbq.h5", "--progress-interval", "0.001", "--quiet"], work)
    assert code == 0 and "fbq.h5:" in stdout
    assert term.strip() == "", term  # neither the live line nor the log lines
