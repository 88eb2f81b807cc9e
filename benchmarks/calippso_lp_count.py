"""How many LPs a certification takes, by the recipe of its input and by N (issue 46; docs/calippso.md §10.13).

    python benchmarks/calippso_lp_count.py --out DIR --n 1024 2048 --recipes ls:1e-3 mls:1e-2 --seeds 1 2 3
    python benchmarks/calippso_lp_count.py --out DIR --reference-example Centers-after-LS--N-1024--d-3.dat
    python benchmarks/calippso_lp_count.py --out benchmarks/records/calippso/lp_count --summarize
    python benchmarks/calippso_lp_count.py --out DIR --gaps --n 1024 --recipes ls:1e-3 mls:1e-2 ls:1e-2 \
        --reference-example Centers-after-LS--N-1024--d-3.dat      # the inputs' near contacts, nothing certified

A recipe makes an N-sphere input at the reference's stop pressure p = 1e5 (sigma = 0, d = 3) from Poisson points:

* ``ls:GAMMA``: LS at compression rate GAMMA to p = 1e5;
* ``mls:GAMMA``: the same LS, then the MLS loop at p_max = 1e5 (rates GAMMA -> 1e-4), so that 1e5 is the packing's own
  pressure (``bench_calippso.ls_start``).

Each input is certified on the default path, with the LP cap ``--max-iterations``, and the certificate is checked on
its own (``bench_calippso.validity``). ``--reference-example`` certifies one of CALiPPSO.jl's example inputs (its
``Examples/Centers-after-LS--N-*--d-3.dat``, read with ``spherejam import``'s reader; not shipped with spherejam) as
one more row. One JSON record per input in ``--out``, written atomically (a rerun skips the records it has), with
the per-LP CSV beside it (``calippso/lp_log.py``) and, while it runs, its checkpoint (``NAME.ckpt.h5``): a rerun
resumes an interrupted certification, from the input kept in ``--inputs`` or rebuilt (the recipes are
deterministic). CPU seconds are this process's on a shared machine.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_calippso import Certificate, ls_start, validity  # noqa: E402

from spherejam.core.atomic import atomic_output  # noqa: E402

PRESSURE = 1e5


def parse_recipe(text: str) -> tuple[str, float]:
    """``ls:GAMMA`` or ``mls:GAMMA`` -> (kind, gamma)."""
    kind, _, rate = text.partition(":")
    if kind not in ("ls", "mls") or not rate:
        raise SystemExit(f"--recipes: {text!r} is not ls:GAMMA or mls:GAMMA")
    return kind, float(rate)


def certify(packing, lp_log: Path, max_iterations: int) -> tuple[Certificate, float]:
    """Certify on the default path, checkpointed beside the LP log (a killed run resumes there when rerun; the
    CPU s are then this call's only)."""
    from spherejam.calippso.run import run_calippso

    t = time.process_time()
    result = run_calippso(packing, max_iterations=max_iterations, lp_log=lp_log, progress_interval=60.0,
                          checkpoint=lp_log.with_suffix("").with_suffix(".ckpt.h5"))
    cpu = time.process_time() - t
    return Certificate.of(result, cpu), cpu


def record(label: str, n: int, packing, build_cpu: float, cert: Certificate, cpu: float) -> dict:
    ok, failed = validity(cert)
    return {"input": label, "n": n, "phi_start": float(packing.phi), "phi_J": float(cert.phi),
            "lps": int(cert.iterations), "converged": bool(cert.completed), "valid": ok, "failed": failed,
            "contacts": int(cert.n_contacts), "rattlers": int(cert.n_rattlers), "build_cpu_s": build_cpu,
            "cpu_s": cpu}


#: Gap thresholds of ``--gaps``: contacts per sphere counted among pairs with h = r_ij / D_ij - 1 below each.
GAP_THRESHOLDS = (1e-6, 1e-5, 3e-5, 1e-4, 1e-3)


def near_contacts(packing) -> str:
    """One table row's cells: 2 (pairs with h below each of :data:`GAP_THRESHOLDS`) / N."""
    i, j, r = packing.pairs_within(1.0 + max(GAP_THRESHOLDS))
    h = r / ((packing.diameters[i] + packing.diameters[j]) / 2.0) - 1.0
    return " | ".join(f"{2 * int((h < t).sum()) / packing.n:.3f}" for t in GAP_THRESHOLDS)


def gaps(args) -> None:
    """The near-contact counts of the inputs ``run`` would certify (rebuilt from their recipes), without certifying."""
    print("| input (p = 1e5) | N | seed | phi | " + " | ".join(f"z(h < {t:g})" for t in GAP_THRESHOLDS) + " |")
    print("|---|---|---|---|" + "---|" * len(GAP_THRESHOLDS))
    if args.reference_example:
        from spherejam.formats import read

        packing = read(args.reference_example, "calippso-jl", box=1.0)
        print(f"| CALiPPSO.jl example | {packing.n} | - | {packing.phi:.6f} | {near_contacts(packing)} |", flush=True)
    for text in args.recipes:
        kind, rate = parse_recipe(text)
        for n in args.n:
            for seed in args.seeds:
                packing, _ = ls_start(n, PRESSURE, rate, seed, kind=kind)
                print(f"| {kind}:{rate:g} | {n} | {seed} | {packing.phi:.6f} | {near_contacts(packing)} |", flush=True)


def write(path: Path, rec: dict) -> None:
    with atomic_output(path) as tmp:
        Path(tmp).write_text(json.dumps(rec, indent=1))
    print(json.dumps(rec), flush=True)


def run(args) -> None:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.reference_example:
        from spherejam.formats import read

        src = Path(args.reference_example)
        name = f"reference-{src.stem}"
        if not (out / f"{name}.json").exists():
            packing = read(src, "calippso-jl", box=1.0)
            cert, cpu = certify(packing, out / f"{name}.lps.csv", args.max_iterations)
            write(out / f"{name}.json", record(f"CALiPPSO.jl example {src.name}", packing.n, packing, 0.0, cert, cpu))
    for text in args.recipes:
        kind, rate = parse_recipe(text)
        for n in args.n:
            for seed in args.seeds:
                name = f"{kind}{rate:g}-n{n}-s{seed}"
                if (out / f"{name}.json").exists():
                    continue
                packing, build_cpu = built(name, kind, rate, n, seed, args.inputs)
                cert, cpu = certify(packing, out / f"{name}.lps.csv", args.max_iterations)
                write(out / f"{name}.json", record(f"{kind}:{rate:g}", n, packing, build_cpu, cert, cpu))


def built(name: str, kind: str, rate: float, n: int, seed: int, inputs: str | None):
    """The input of a recipe, built, or read from ``inputs`` where an earlier run kept it (kept there when built):
    a rerun after a kill resumes its certification without rebuilding. Returns (packing, CPU s of the build; nan
    when read)."""
    from spherejam.core.packing_io import read_packing, write_packing

    kept = Path(inputs) / f"{name}.h5" if inputs else None
    if kept is not None and kept.exists():
        return read_packing(kept), math.nan
    t = time.process_time()
    packing, _ = ls_start(n, PRESSURE, rate, seed, kind=kind)
    if kept is not None:
        kept.parent.mkdir(parents=True, exist_ok=True)
        write_packing(kept, packing)
    return packing, time.process_time() - t


def summarize(out: Path) -> None:
    recs = [json.loads(Path(f).read_text()) for f in sorted(glob.glob(str(out / "*.json")))]
    groups: dict[tuple[str, int], list[dict]] = {}
    for r in recs:
        groups.setdefault((r["input"], r["n"]), []).append(r)
    print("| input (p = 1e5) | N | inputs | LPs, each | LPs, median | LPs, mean | phi_J - phi_start, median | "
          "CPU s / LP | converged, valid |")
    print("|---|---|---|---|---|---|---|---|---|")
    for (label, n), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1])):
        lps = [r["lps"] for r in rs]
        per_lp = sum(r["cpu_s"] for r in rs) / max(sum(lps), 1)
        dphi = statistics.median(r["phi_J"] - r["phi_start"] for r in rs)
        each = ", ".join(f"{r['lps']}" + ("" if r["converged"] else " (cap)") for r in rs)
        print(f"| {label} | {n} | {len(rs)} | {each} | "
              f"{statistics.median(lps):g} | {statistics.mean(lps):.1f} | {dphi:.1e} | {per_lp:.2g} | "
              f"{sum(r['converged'] for r in rs)}, {sum(r['valid'] for r in rs)} of {len(rs)} |")
    if not recs:
        print(f"no records in {out} (n = 0)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="folder of the per-input records")
    ap.add_argument("--n", type=int, nargs="*", default=[1024])
    ap.add_argument("--recipes", nargs="*", default=["ls:1e-3", "mls:1e-2"], help="ls:GAMMA or mls:GAMMA")
    ap.add_argument("--seeds", type=int, nargs="*", default=[1, 2, 3])
    ap.add_argument("--max-iterations", type=int, default=1000)
    ap.add_argument("--inputs", help="folder where the built inputs are kept and read again (not the records')")
    ap.add_argument("--reference-example", help="a CALiPPSO.jl Examples/Centers-after-LS--N-*--d-3.dat file")
    ap.add_argument("--summarize", action="store_true", help="print the table of the records in --out and stop")
    ap.add_argument("--gaps", action="store_true", help="print the inputs' near-contact counts and stop")
    args = ap.parse_args(argv)
    if args.summarize:
        summarize(Path(args.out))
    elif args.gaps:
        gaps(args)
    else:
        run(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
