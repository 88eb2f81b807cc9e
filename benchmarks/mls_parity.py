"""MLS parity: our closest-jamming search against the paper's own C++ code (``-lsgd``) on identical starts (issue 24).

Each *pair* is one start packing made by OUR code (Poisson seed s -> FB at gamma = ``--start-rate``, or LS at that
rate), given to both codes; with ``--start FILE`` every pair starts from that packing instead (any format
``spherejam`` reads, e.g. a workflow's ``initial.h5``) and only the velocity seed s differs:

* ours: :func:`spherejam.find_closest_jamming` (gamma_0, f, final rate as given, p_max = 1e12, 50 equilibration
  windows, velocity seed s);
* the C++ code (VasiliBaranov/packing-generation, built by you outside this repo, path in ``--exe``): the start is
  written in its input format (``packing.xyzd``: little-endian float64 ``x y z D`` per sphere, with the nominal
  diameters D = d / mean(d), i.e. exactly our engine's nominal diameters, so both codes grow the spheres at the same
  d D_i / dt = gamma D_i; ``generation.conf`` with ``Generation start: 0``, ``Seed: s`` and the three MLS rates), run
  with ``-lsgd`` in that folder. phi_J is read from its ``packing.nfo`` (``1 - Final Porosity``). Per-window figures
  (collisions, rate, scale factor, pressure) need a binary that prints, once per window, a line
  ``PARITY collisions C rate G ratio R pressure P time T cpu S``; a stock binary gives phi_J, stop and CPU only.

Searches are cut at a number of collisions and recorded as ``capped``: the C++ run at
``--max-collisions-per-particle`` x N (SIGINT once its log passes that count, so it needs the PARITY lines), ours at
``--ours-max-collisions-per-particle`` x N (``max_collisions``: deterministic; default the C++ cap). A capped result
is redone by a later call with a higher cap; the summary shows phi at the cap as a lower bound of phi_J and counts
a capped search as costlier than its cap. CPU seconds per search are measured here: ``time.process_time`` around
our call (after a warm-up search, so no compilation is charged), and the child's user + system time
(``resource.getrusage(RUSAGE_CHILDREN)``) for the C++ process.

One JSON file per pair and code (``OUT/<cell>/pair-SSSS/{ours,cpp}.json``, written atomically); a rerun skips what is
done, so the command is resumable. ``--summarize`` prints the table of every cell in OUT (docs/mls_parity.md).

    nice -n 15 python benchmarks/mls_parity.py --out /tmp/parity --exe <PackingGeneration.exe> \\
        --n 500 --sigma 0 --pairs 10 --ours-max-collisions-per-particle 1e6
    python benchmarks/mls_parity.py --out /tmp/parity --summarize
    python benchmarks/mls_parity.py --out /tmp/parity --exe <exe> --start <initial.h5> --initial-rate 10 --seeds 1 2
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import json
import math
import os
import re
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from spherejam import find_closest_jamming, poisson_packing, run_fb, run_ls
from spherejam.core.atomic import atomic_output
from spherejam.core.packing_io import read_packing
from spherejam.formats import packing_generation as pg

P_MAX = 1e12
MAX_EQUILIBRATION_WINDOWS = 50
#: A compression stage "unjams" when its lowest window pressure falls below this (issue 24).
UNJAM_PRESSURE = 1e6
#: "Late" compression stages (issue 24: gamma <= 3e-4 with gamma_0 = 1e-2, f = 2).
LATE_RATE = 3.2e-4
#: Fewer complete pairs than this: tests and spreads are printed as "not estimable".
MIN_PAIRS_FOR_TEST = 5
_PARITY = re.compile(r"^PARITY collisions (\d+) rate (\S+) ratio (\S+) pressure (\S+) time (\S+) cpu (\S+)")


# --- starts ---------------------------------------------------------------------------------------------------------

def make_start(n: int, sigma: float, seed: int, kind: str, rate: float):
    """The pair's start packing, made by our code: Poisson (phi_nominal 0.6) -> FB or LS at ``rate``."""
    poisson = poisson_packing(n, sigma, seed=seed, phi_nominal=0.6)
    if kind == "fb":
        return run_fb(poisson, rate, progress_interval=1e9).packing
    return run_ls(poisson, rate, seed=seed, progress_interval=1e9).packing


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


# --- the two searches -------------------------------------------------------------------------------------------

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


def run_ours(start, seed: int, initial_rate: float, factor: float, final_rate: float, max_collisions: int,
             **options) -> dict:
    """Our search; ``options`` go to :func:`find_closest_jamming` (e.g. ``stall_windows``)."""
    cpu0, wall0 = time.process_time(), time.perf_counter()
    r = find_closest_jamming(start, initial_rate=initial_rate, decrease_factor=factor, final_rate=final_rate,
                             p_max=P_MAX, max_equilibration_windows=MAX_EQUILIBRATION_WINDOWS, seed=seed,
                             max_collisions=max_collisions, progress_interval=1e9, **options)
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    h = r.history
    cols = {k: np.asarray(h[k]).tolist() for k in ("phi", "pressure", "rate", "collisions", "duration") if k in h}
    collisions = int(np.sum(h["collisions"]))
    stop = stop_reason(cols["rate"], cols["pressure"], final_rate)
    res = {"code": "ours", "phi_J": float(r.packing.phi), "stop": stop, "cpu_s": cpu, "wall_s": wall,
           "collisions": collisions, "windows": len(cols["phi"]), "history": cols}
    return classify(res, max_collisions)


def classify(res: dict, max_collisions: int) -> dict:
    """Mark our search as capped if it ended at the collision cap without meeting a stop rule (the cap is checked
    after the MLS rules, so a search that stops exactly at the cap window by a rule keeps that rule)."""
    capped = res["collisions"] >= max_collisions and res["stop"] not in ("final_rate", "jammed")
    res["capped"] = capped
    if capped:
        res["stop"], res["phi_J"] = "capped", None
    return res


def stop_reason(rate, pressure, final_rate: float) -> str:
    """Why a search ended, from its last windows (the MLS rules of docs/algorithms.md §3)."""
    if not rate:
        return "unfinished"
    if 0 < rate[-1] <= final_rate:
        return "final_rate" if pressure[-1] >= P_MAX else "final_rate_stalled"
    tail = MAX_EQUILIBRATION_WINDOWS
    if len(rate) >= tail and all(g == 0 for g in rate[-tail:]) and all(p >= P_MAX for p in pressure[-tail:]):
        return "jammed"
    return "unfinished"


# --- stages and the summary ---------------------------------------------------------------------------------------

def stages(history: dict[str, list]) -> list[dict]:
    """Maximal runs of windows at one rate: rate, windows, lowest and last pressure, phi at the end."""
    out: list[dict] = []
    for g, p, phi in zip(history.get("rate", []), history.get("pressure", []), history.get("phi", [])):
        if out and out[-1]["rate"] == g:
            s = out[-1]
            s["windows"] += 1
            s["p_min"] = min(s["p_min"], p)
            s["p_end"], s["phi_end"] = p, phi
        else:
            out.append({"rate": g, "windows": 1, "p_min": p, "p_end": p, "phi_end": phi})
    return out


def stage_figures(result: dict) -> dict:
    """Windows per compression stage (by rate), unjammed fraction of the re-compressions, stalls."""
    st = stages(result.get("history") or {})
    if result.get("capped"):
        st = st[:-1]  # the stage the cap cut is unfinished
    comp = [s for s in st if s["rate"] > 0]
    later = comp[1:]  # every compression after the first starts from a (nearly) jammed state
    return {
        "compression_windows": [s["windows"] for s in comp],
        "compression_rates": [s["rate"] for s in comp],
        "equilibration_windows": [s["windows"] for s in st if s["rate"] == 0],
        "unjammed": sum(s["p_min"] < UNJAM_PRESSURE for s in later), "recompressions": len(later),
        "late": [(s["windows"], s["p_min"] < UNJAM_PRESSURE) for s in later if s["rate"] <= LATE_RATE],
        "stalled": sum(s["p_end"] < P_MAX for s in comp[:-1]),
    }


def _fmt(values, digits=4) -> str:
    v = np.asarray([x for x in values if x is not None], dtype=float)
    if v.size == 0:
        return "–"
    if v.size == 1:
        return f"{v[0]:.{digits}g} (n = 1)"
    return f"{v.mean():.{digits}g} ± {v.std(ddof=1):.2g} (n = {v.size})"


def _median_spread(values) -> str:
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return "–"
    if v.size < MIN_PAIRS_FOR_TEST:
        return f"median {np.median(v):.3g}, values {', '.join(f'{x:.3g}' for x in sorted(v))} (n = {v.size})"
    return (f"median {np.median(v):.3g}, IQR {np.percentile(v, 25):.3g}–{np.percentile(v, 75):.3g}, "
            f"range {v.min():.3g}–{v.max():.3g} (n = {v.size})")


def tests(ours: list[float], cpp: list[float]) -> str:
    """Paired Wilcoxon signed-rank test and Mann–Whitney U on phi_J of the complete pairs."""
    n = len(ours)
    if n < MIN_PAIRS_FOR_TEST:
        return f"not estimable (n = {n} complete pairs; a test needs >= {MIN_PAIRS_FOR_TEST})"
    from scipy import stats

    w = stats.wilcoxon(ours, cpp)
    u = stats.mannwhitneyu(ours, cpp, alternative="two-sided")
    d = np.asarray(ours) - np.asarray(cpp)
    return (f"paired diff ours - C++ = {d.mean():+.4f} ± {d.std(ddof=1) / math.sqrt(n):.4f} (s.e.); "
            f"Wilcoxon signed-rank p = {w.pvalue:.3g}; Mann–Whitney U = {u.statistic:.0f}, p = {u.pvalue:.3g} "
            f"(n = {n})")


def _phi_cell(r: dict | None) -> str:
    """phi_J, or for a capped search "≥ phi" at the cap (phi only grows during MLS, so it bounds phi_J)."""
    if r is None:
        return "–"
    if r["phi_J"] is not None:
        return f"{r['phi_J']:.5f}"
    phi = (r.get("history") or {}).get("phi")
    return f"≥ {phi[-1]:.5f}" if phi else "–"


def _phi_end(r: dict) -> float | None:
    phi = (r.get("history") or {}).get("phi")
    return r["phi_J"] if r["phi_J"] is not None else (phi[-1] if phi else None)


def censored_phi_sign_test(pairs: list[tuple[dict, dict]]) -> str:
    """Is our phi_J lower than the C++ one? A capped search's phi_J is at least its phi at the cap, so a pair is
    decided when both finished, or when the finished one lies below the other's phi at the cap."""
    lower = higher = undecided = 0
    for o, c in pairs:
        po, pc = _phi_end(o), _phi_end(c)
        if po is None or pc is None or (o["capped"] and c["capped"]):
            undecided += 1
        elif not (o["capped"] or c["capped"]):
            lower += po < pc
            higher += po >= pc
        elif c["capped"] and po < pc:
            lower += 1
        elif o["capped"] and pc < po:
            higher += 1
        else:
            undecided += 1
    n = lower + higher
    text = f"ours lower in {lower}, higher in {higher} of {n} decided pairs ({undecided} undecided)"
    if n < MIN_PAIRS_FOR_TEST:
        return text + f"; sign test not estimable (n = {n})"
    from scipy import stats

    return text + f"; sign test p = {stats.binomtest(lower, n).pvalue:.3g}"


def censored_sign_test(pairs: list[tuple[dict, dict]]) -> str:
    """Does our search need fewer collisions than the C++ one? Per pair, decided where possible: both finished, or
    one capped while the other finished below that cap. A sign test on the decided pairs."""
    fewer = more = undecided = 0
    for o, c in pairs:
        if o["capped"] and c["capped"]:
            undecided += 1
        elif c["capped"] and o["collisions"] < c["collisions"]:
            fewer += 1
        elif o["capped"] and c["collisions"] < o["collisions"]:
            more += 1
        elif not (o["capped"] or c["capped"]):
            fewer += o["collisions"] < c["collisions"]
            more += o["collisions"] >= c["collisions"]
        else:
            undecided += 1
    n = fewer + more
    text = f"ours needed fewer collisions in {fewer} of {n} decided pairs ({undecided} undecided)"
    if n < MIN_PAIRS_FOR_TEST:
        return text + f"; sign test not estimable (n = {n})"
    from scipy import stats

    return text + f"; sign test p = {stats.binomtest(fewer, n).pvalue:.3g}"


def fisher_line(rows: dict[str, list]) -> str:
    """Fisher's exact test: do late stages unjam (p_min < 1e6) as often in both codes?"""
    counts = {}
    for code in ("ours", "cpp"):
        late = [u for _, r in rows[code] if r.get("history", {}).get("rate") for _, u in r["stage"]["late"]]
        counts[code] = (sum(late), len(late) - sum(late))
    (a, b), (c, d) = counts["ours"], counts["cpp"]
    text = f"{a} of {a + b} against {c} of {c + d}"
    if min(a + b, c + d) < MIN_PAIRS_FOR_TEST:
        return text + f"; not estimable (n = {a + b}, {c + d} stages)"
    from scipy import stats

    return text + f"; Fisher exact p = {stats.fisher_exact([[a, b], [c, d]]).pvalue:.3g}"


def summarize(out: Path) -> None:
    for cell in sorted(p for p in out.iterdir() if p.is_dir()):
        pairs = []
        for pair in sorted(cell.glob("pair-*")):
            res = {}
            for code in ("ours", "cpp"):
                f = pair / f"{code}.json"
                if f.is_file():
                    res[code] = json.loads(f.read_text())
                    if code == "ours":
                        classify(res[code], res[code]["max_collisions"])
            if res:
                pairs.append((pair.name, res))
        if not pairs:
            continue
        print(f"\n## {cell.name}: {len(pairs)} pair(s) started\n")
        print("| pair | phi_start | phi_J ours | phi_J C++ | stop ours / C++ | collisions ours / C++ "
              "| CPU s ours / C++ | windows ours / C++ | unjammed re-compressions ours / C++ |")
        print("|---|---|---|---|---|---|---|---|---|")
        rows = {"ours": [], "cpp": []}
        for name, res in pairs:
            cells = []
            for code in ("ours", "cpp"):
                r = res.get(code)
                if r is not None:
                    r["stage"] = stage_figures(r)
                    rows[code].append((name, r))
            o, c = res.get("ours"), res.get("cpp")

            def g(r, k, f="{}"):
                return "–" if r is None or r.get(k) is None else f.format(r[k])

            def uj(r):
                if r is None or not r.get("history", {}).get("rate"):
                    return "–"
                return f"{r['stage']['unjammed']}/{r['stage']['recompressions']}"
            phi0 = (o or c or {}).get("phi_start")
            cells = [name, "–" if phi0 is None else f"{phi0:.5f}", _phi_cell(o), _phi_cell(c),
                     f"{g(o, 'stop')} / {g(c, 'stop')}",
                     f"{g(o, 'collisions', '{:.3g}')} / {g(c, 'collisions', '{:.3g}')}",
                     f"{g(o, 'cpu_s', '{:.0f}')} / {g(c, 'cpu_s', '{:.0f}')}",
                     f"{g(o, 'windows')} / {g(c, 'windows')}", f"{uj(o)} / {uj(c)}"]
            print("| " + " | ".join(cells) + " |")
        complete = [(res["ours"], res["cpp"]) for _, res in pairs
                    if "ours" in res and "cpp" in res and res["ours"]["phi_J"] is not None
                    and res["cpp"]["phi_J"] is not None]
        print()
        for code, label in (("ours", "ours"), ("cpp", "C++ ")):
            rs = [r for _, r in rows[code]]
            done = [r for r in rs if r["phi_J"] is not None]
            capped = sum(r["capped"] for r in rs)
            # stage figures from every search with a history, capped ones too (without their cut stage): the
            # capped searches are the ones with the long stages
            traced = [r for r in rs if r.get("history", {}).get("rate")]
            comp = [w for r in traced for w in r["stage"]["compression_windows"]]
            unj = sum(r["stage"]["unjammed"] for r in traced)
            rec = sum(r["stage"]["recompressions"] for r in traced)
            stalled = sum(r["stage"]["stalled"] for r in traced)
            print(f"- {label}: phi_J {_fmt([r['phi_J'] for r in done], 5)}; capped {capped} of {len(rs)}; "
                  f"collisions/search {_fmt([r['collisions'] for r in done], 3)}; CPU s/search "
                  f"{_fmt([r['cpu_s'] for r in done], 3)}; windows/search {_fmt([r['windows'] for r in done], 3)}")
            if comp:
                first = [r["stage"]["compression_windows"][0] for r in traced if r["stage"]["compression_windows"]]
                later = [w for r in traced for w in r["stage"]["compression_windows"][1:]]
                eq = [w for r in traced for w in r["stage"]["equilibration_windows"]]
                print(f"  - windows per compression stage: first (gamma_0) {_fmt(first, 3)}; later stages "
                      f"median {np.median(later) if later else float('nan'):.0f}, mean {_fmt(later, 3)}; "
                      f"equilibration windows per stage {_fmt(eq, 2)}")
                print(f"  - stage figures from {len(traced)} searches (capped ones without their cut stage)")
                print(f"  - re-compressions that unjam below p = {UNJAM_PRESSURE:.0e}: {unj} of {rec}"
                      + (f" = {unj / rec:.2f}" if rec else "") + f"; stages ended by our stall rule: {stalled}")
                late = [x for r in traced for x in r["stage"]["late"]]
                if late:
                    print(f"  - late stages (gamma <= {LATE_RATE:g}): {sum(u for _, u in late)} of {len(late)} unjam; "
                          f"windows median {np.median([w for w, _ in late]):.0f}, mean {_fmt([w for w, _ in late], 3)}")
        print("- late-stage unjamming, ours vs C++: " + fisher_line(rows))
        started = [(res["ours"], res["cpp"]) for _, res in pairs if "ours" in res and "cpp" in res]
        print("- phi_J with capped searches bounded below by phi at the cap: " + censored_phi_sign_test(started))
        print(f"- phi_J test: {tests([o['phi_J'] for o, _ in complete], [c['phi_J'] for _, c in complete])}")
        # cost per collision does not need a finished search
        both = [(res["ours"], res["cpp"]) for _, res in pairs if "ours" in res and "cpp" in res
                and res["ours"].get("collisions") and res["cpp"].get("collisions")]
        print("- cost with capped searches counted as larger than their cap: " + censored_sign_test(started))
        print("- speed ratio per search, C++ CPU / our CPU: "
              + _median_spread([c["cpu_s"] / o["cpu_s"] for o, c in complete]))
        bounds = [c["cpu_s"] / o["cpu_s"] for _, res in pairs if "ours" in res and "cpp" in res
                  for o, c in [(res["ours"], res["cpp"])] if c["capped"] and not o["capped"]]
        if bounds:
            print("  - pairs where only the C++ search was capped (ratio >= value): "
                  + ", ".join(f"{x:.3g}" for x in sorted(bounds)))
        print("- speed ratio per collision, (C++ CPU/collision) / (our CPU/collision): "
              + _median_spread([(c['cpu_s'] / c['collisions']) / (o['cpu_s'] / o['collisions']) for o, c in both]))
        print("- collisions per search, ours / C++ (complete pairs): "
              + _median_spread([o["collisions"] / c["collisions"] for o, c in complete]))


# --- driver ----------------------------------------------------------------------------------------------------------

def _done(path: Path, cap: int) -> bool:
    """A result exists, and unless it was capped below ``cap`` it need not be redone."""
    if not path.is_file():
        return False
    res = json.loads(path.read_text())
    if res["code"] == "ours":
        classify(res, res["max_collisions"])
    return not (res["capped"] and res["max_collisions"] < cap)


def claim(path: Path) -> bool:
    """Take the lock file ``path`` for this process (False: a live process holds it).

    Two workers on overlapping seeds must not run the same search: the C++ code reads and writes fixed file names in
    its folder. A lock whose process has died is taken over.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    for _ in range(2):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            try:
                pid = int(path.read_text() or "0")
                os.kill(pid, 0)
                return False  # alive
            except (ValueError, ProcessLookupError):
                path.unlink(missing_ok=True)  # stale
                continue
            except PermissionError:
                return False
        with os.fdopen(fd, "w") as f:
            f.write(str(os.getpid()))
        return True
    return False


def _write_json(path: Path, data: dict) -> None:
    with atomic_output(path) as tmp:
        tmp.write_text(json.dumps(data))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="scratch folder (one sub-folder per cell)")
    ap.add_argument("--summarize", action="store_true", help="print the table of every cell in --out and exit")
    ap.add_argument("--exe", help="the C++ PackingGeneration binary")
    ap.add_argument("--n", type=int, default=500)
    ap.add_argument("--sigma", type=float, default=0.0)
    ap.add_argument("--pairs", type=int, default=10, help="number of start packings (pairs)")
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--seeds", type=int, nargs="*", help="explicit pair seeds (overrides --pairs/--first-seed)")
    ap.add_argument("--start-kind", choices=("fb", "ls"), default="fb")
    ap.add_argument("--start-rate", type=float, default=1e-3, help="gamma of the FB (or LS) start")
    ap.add_argument("--start", type=Path, help="one start packing for every pair (overrides --n, --sigma, "
                    "--start-kind and --start-rate; the pair seed is then the velocity seed only)")
    ap.add_argument("--initial-rate", type=float, default=1e-2)
    ap.add_argument("--factor", type=float, default=2.0)
    ap.add_argument("--final-rate", type=float, default=1e-4)
    ap.add_argument("--max-collisions-per-particle", type=float, default=2e5, help="cap per C++ search")
    ap.add_argument("--ours-max-collisions-per-particle", type=float, default=None,
                    help="cap per search of ours (default: the C++ cap; ours is cheaper per collision)")
    ap.add_argument("--stall-windows", default="default",
                    help="our stall rule: 'default' (the production value), 'none' (off) or an integer")
    ap.add_argument("--codes", nargs="*", choices=("ours", "cpp"), default=["ours", "cpp"])
    args = ap.parse_args(argv)
    if args.summarize:
        summarize(args.out)
        return
    if "cpp" in args.codes and not args.exe:
        ap.error("--exe is required to run the C++ code")
    options = {} if args.stall_windows == "default" else {
        "stall_windows": None if args.stall_windows == "none" else int(args.stall_windows)}
    given = read_packing(args.start) if args.start else None
    if given is not None:
        args.n, args.sigma = given.n, round(float(np.std(given.diameters) / np.mean(given.diameters)), 3)
        tag = hashlib.sha1(str(args.start.resolve()).encode()).hexdigest()[:8]
        cell = args.out / f"N{args.n}-start-{tag}"
    else:
        cell = args.out / f"N{args.n}-sigma{args.sigma:g}-{args.start_kind}{args.start_rate:g}"
    cell.mkdir(parents=True, exist_ok=True)
    seeds = args.seeds or list(range(args.first_seed, args.first_seed + args.pairs))
    caps = {"cpp": int(args.max_collisions_per_particle * args.n),
            "ours": int((args.ours_max_collisions_per_particle or args.max_collisions_per_particle) * args.n)}
    common = {"stall_windows": args.stall_windows, "n": args.n, "sigma": args.sigma,
              "start_kind": None if args.start else args.start_kind,
              "start_rate": None if args.start else args.start_rate,
              "initial_rate": args.initial_rate, "factor": args.factor, "final_rate": args.final_rate,
              "start_file": str(args.start) if args.start else None}
    for seed in seeds:
        folder = cell / f"pair-{seed:04d}"
        todo = [c for c in args.codes if not _done(folder / f"{c}.json", caps[c])]
        if not todo:
            continue
        start = given if given is not None else make_start(args.n, args.sigma, seed, args.start_kind,
                                                           args.start_rate)
        meta = dict(common, seed=seed, phi_start=float(start.phi))
        folder.mkdir(parents=True, exist_ok=True)
        for code in todo:
            lock = folder / f"{code}.lock"
            if not claim(lock):
                print(f"    seed {seed} {code}: another worker is on it, skipped", flush=True)
                continue
            try:
                if not _done(folder / f"{code}.json", caps[code]):  # another worker may have just finished it
                    _run_one(args, code, folder, seed, start, meta, caps[code], options)
            finally:
                lock.unlink(missing_ok=True)


def _run_one(args, code: str, folder: Path, seed: int, start, meta: dict, cap: int, options: dict) -> None:
    """One search of one pair (the C++ run, or ours), recorded in ``folder/<code>.json``."""
    print(f"[{time.strftime('%H:%M:%S')}] {folder.parent.name} seed {seed}: {code} from phi = {start.phi:.5f}",
          flush=True)
    if code == "cpp" and (folder / "cpp" / pg.NFO).is_file() and (folder / "cpp" / "log.txt").is_file():
        res = collect_cpp(folder / "cpp", nominal_density(start))  # finished, but not recorded
    elif code == "cpp":
        phi_nom = write_cpp_input(start, folder / "cpp", seed, args.initial_rate, args.factor, args.final_rate)
        res = run_cpp(args.exe, folder / "cpp", phi_nom, cap)
    else:
        _warm_up()
        res = run_ours(start, seed, args.initial_rate, args.factor, args.final_rate, cap, **options)
    res.update(meta, max_collisions=cap)
    _write_json(folder / f"{code}.json", res)
    print(f"    phi_J = {res['phi_J']} stop = {res['stop']} collisions = {res['collisions']} "
          f"CPU = {res['cpu_s']:.1f} s windows = {res['windows']}", flush=True)


@functools.cache
def _warm_up() -> None:
    """Load/compile the kernels once, outside the timed searches."""
    find_closest_jamming(poisson_packing(64, 0.0, seed=0), initial_rate=1.0, max_collisions=2000, progress_interval=1e9)


if __name__ == "__main__":
    sys.exit(main())
