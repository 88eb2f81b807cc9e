"""The C++ side of a pair: its input files, the ``-lsgd`` run cut at a collision cap, its log and its result."""

from __future__ import annotations

import math
import os
import re
import resource
import signal
import subprocess
import time
from pathlib import Path

import numpy as np

from spherejam.core.atomic import atomic_output
from spherejam.formats import packing_generation as pg

_PARITY = re.compile(r"^PARITY collisions (\d+) rate (\S+) ratio (\S+) pressure (\S+) time (\S+) cpu (\S+)")


def write_cpp_input(start, folder: Path, seed: int, initial_rate: float, factor: float, final_rate: float) -> float:
    """``packing.xyzd`` + ``generation.conf`` for ``-lsgd``; returns phi of the nominal diameters (phi = that x r^3).

    No ``packing.nfo`` is written: the code skips any folder that has one. The optional conf lines must come in the
    order the code scans them (Generation mode, Final contraction rate, Contraction rate decrease factor).
    """
    folder.mkdir(parents=True, exist_ok=True)
    nominal = start.diameters / start.diameters.mean()  # our engine's nominal diameters (docs/mls_parity.md)
    data = np.column_stack([start.positions, nominal]).astype("<f8")
    box = float(start.box)
    with atomic_output(folder / pg.XYZD) as tmp:
        data.tofile(tmp)
    conf = (f"Particles count: {start.n}\nPacking size: {box!r} {box!r} {box!r}\nGeneration start: 0\n"
            f"Seed: {seed}\nSteps to write: 1000000\nBoundaries mode: 1\nContraction rate: {initial_rate!r}\n"
            f"Generation mode: 1\nFinal contraction rate: {final_rate!r}\n"
            f"Contraction rate decrease factor: {factor!r}\n")
    (folder / pg.CONF).write_text(conf)
    (folder / pg.NFO).unlink(missing_ok=True)
    return nominal_density(start)


def nominal_density(start) -> float:
    """phi of the mean-1 nominal diameters in the box: the C++ code's phi is this times r^3."""
    nominal = start.diameters / start.diameters.mean()
    return float(np.sum(math.pi / 6.0 * nominal**3) / start.box**3)


def _child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def parse_cpp_log(text: str, phi_nominal: float) -> dict[str, list]:
    """Per-window columns from the ``PARITY`` lines of a C++ log (empty lists for a stock binary)."""
    cols: dict[str, list] = {"phi": [], "pressure": [], "rate": [], "collisions": [], "duration": []}
    for line in text.splitlines():
        m = _PARITY.match(line)
        if m:
            cols["collisions"].append(int(m.group(1)))
            cols["rate"].append(float(m.group(2)))
            cols["phi"].append(phi_nominal * float(m.group(3)) ** 3)
            cols["pressure"].append(float(m.group(4)))
            cols["duration"].append(float(m.group(5)))
    return cols


def run_cpp(exe: str, folder: Path, phi_nominal: float, max_collisions: int, poll: float = 2.0) -> dict:
    """Run ``exe -lsgd`` in ``folder`` (line-buffered stdout to log.txt), cut at ``max_collisions``."""
    log = folder / "log.txt"
    cmd = (["stdbuf", "-oL"] if _have("stdbuf") else []) + [exe, "-lsgd"]
    cpu0, wall0 = _child_cpu(), time.perf_counter()
    capped = False
    with open(log, "w") as out:
        proc = subprocess.Popen(cmd, cwd=folder, stdout=out, stderr=subprocess.STDOUT)
        while proc.poll() is None:
            time.sleep(poll)
            done = sum(parse_cpp_log(log.read_text(errors="replace"), phi_nominal)["collisions"])
            if done >= max_collisions:
                capped = True
                proc.send_signal(signal.SIGINT)
                try:
                    proc.wait(30)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
    return collect_cpp(folder, phi_nominal, capped, _child_cpu() - cpu0, time.perf_counter() - wall0,
                       proc.returncode)


def collect_cpp(folder: Path, phi_nominal: float, capped: bool = False, cpu: float | None = None,
                wall: float | None = None, returncode: int | None = None) -> dict:
    """The result of a C++ run from its folder (log.txt, packing.nfo). Without a measured ``cpu`` (a run whose
    worker died before recording it) the CPU time is the nfo's ``Total Simulation Time`` (generation loop only)."""
    text = (folder / "log.txt").read_text(errors="replace")
    cols = parse_cpp_log(text, phi_nominal)
    nfo = folder / pg.NFO
    phi_j, stop, reported_cpu = None, "capped" if capped else "error", None
    if nfo.is_file() and not capped:
        info = {k.strip().lower(): v.split()[0] for k, _, v in
                (line.partition(":") for line in nfo.read_text().splitlines()) if v.strip()}
        phi_j = 1.0 - float(info["final porosity"])  # "0.36 (Tolerance: 1.0001)" -> "0.36"
        reported_cpu = float(info["total simulation time"])
        stop = "jammed" if "almost jammed" in text else "final_rate"
    return {"code": "cpp", "phi_J": phi_j, "stop": stop, "capped": capped,
            "cpu_s": reported_cpu if cpu is None else cpu, "cpu_source": "nfo" if cpu is None else "rusage",
            "wall_s": wall, "reported_cpu_s": reported_cpu, "returncode": returncode,
            "collisions": int(sum(cols["collisions"])) if cols["collisions"] else None,
            "windows": len(cols["phi"]) or None, "history": cols}


def _have(tool: str) -> bool:
    return any((Path(p) / tool).is_file() for p in os.environ.get("PATH", "").split(os.pathsep))
