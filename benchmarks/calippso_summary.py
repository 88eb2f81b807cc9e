"""The summary of one whole CALiPPSO certification, for benchmarks/records/calippso/ (issue 46).

    python benchmarks/calippso_summary.py OUT.calippso.h5 --record benchmarks/records/calippso/NAME.lps.csv \
        --name NAME --out benchmarks/records/calippso/NAME.summary.json [--key clean] [--note TEXT]

Reads the certified output (``spherejam calippso -o``) and its per-LP record (``--lp-log``), checks the certificate
again (converged, isostatic, force balance <= 1e-10, no overlap beyond 1e-10 of a diameter) and writes its figures
under ``--key`` of the JSON file, keeping the file's other keys (a resumed run and a clean re-run of one input sit
side by side). A certificate that fails a check is refused with one line and exit status 1: it never becomes a
record. ``calippso_cost_fit.py`` reads these files (the whole-run rows of the cost model, docs/cluster.md §3).
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

FORCE_BALANCE_MAX = 1e-10
OVERLAP_MAX = 1e-10


def summary(output: Path, record: Path, name: str, note: str | None) -> dict:
    """The summary of certified output ``output``; raises ValueError naming the check a certificate fails."""
    from spherejam.core.packing_io import read_packing

    packing = read_packing(output, tolerance=None)  # checked below, with the worst overlap in the record
    counters = packing.metadata.get("counters", {})
    if packing.metadata.get("algorithm") != "calippso" or not counters:
        raise ValueError(f"{output}: not a CALiPPSO output")
    worst = packing.check(OVERLAP_MAX).worst_overlap
    checks = {
        "converged": counters.get("converged") is True,
        "isostatic": counters.get("isostatic") is True,
        f"force balance <= {FORCE_BALANCE_MAX:g}": counters.get("force_balance_residual", 1.0) <= FORCE_BALANCE_MAX,
        f"worst overlap <= {OVERLAP_MAX:g}": worst <= OVERLAP_MAX,
    }
    failed = [label for label, ok in checks.items() if not ok]
    if failed:
        raise ValueError(f"{output}: the certificate fails: {', '.join(failed)}")
    with open(record) as fh:
        rows = list(csv.DictReader(fh))
    if len(rows) != counters["iterations"]:
        raise ValueError(f"{record}: {len(rows)} LPs, the output says {counters['iterations']}")
    provenance = packing.metadata.get("provenance", {})
    out = {
        "input": name,
        "n": packing.n,
        "record": record.name,
        "converged": True,
        "iterations": int(counters["iterations"]),
        "phi_initial": counters["phi_initial"],
        "phi_final": counters["phi_final"],
        "n_contacts": int(counters["n_contacts"]),
        "n_rattlers": int(counters["n_rattlers"]),
        "isostatic": True,
        "force_balance_residual": counters["force_balance_residual"],
        "worst_overlap": worst,
        "iteration_cpu_s_total": round(sum(float(r["iteration_cpu_s"]) for r in rows), 1),
        "lp_cpu_s_with_force_lp": round(float(counters["lp_cpu_time"]), 1),
        "wall_s": round(float(counters["wall_time"]), 1),
        "lp_methods": counters.get("lp_methods", {}),
        "git_commit": provenance.get("git_commit"),
        "created": provenance.get("created"),
    }
    if note:
        out["note"] = note
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("output", type=Path, help="the certified packing (spherejam calippso -o)")
    ap.add_argument("--record", type=Path, required=True, help="its per-LP CSV (spherejam calippso --lp-log)")
    ap.add_argument("--name", required=True, help="the input's name (a fixture of calippso_fixtures.py)")
    ap.add_argument("--out", type=Path, required=True, help="the summary JSON (created, or its --key replaced)")
    ap.add_argument("--key", default="clean", help="the key of this run in the JSON (clean)")
    ap.add_argument("--note", help="a remark kept with the figures")
    args = ap.parse_args(argv)
    from spherejam.core.atomic import atomic_output

    try:
        entry = summary(args.output, args.record, args.name, args.note)
    except (OSError, ValueError, KeyError) as exc:
        print(f"calippso_summary: {exc}", file=sys.stderr)
        return 1
    data = json.loads(args.out.read_text()) if args.out.exists() else {}
    data[args.key] = entry
    with atomic_output(args.out) as tmp:
        Path(tmp).write_text(json.dumps(data, indent=1) + "\n")
    print(f"{args.out}: {args.key}: {entry['iterations']} LPs, {entry['lp_cpu_s_with_force_lp']} CPU-s, "
          f"phi_J {entry['phi_final']:.10f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
