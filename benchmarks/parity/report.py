"""The Markdown table and summary lines of every cell of an output folder (``--summarize``)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .ours import classify
from .significance import (MIN_PAIRS_FOR_TEST, censored_phi_sign_test, censored_sign_test, fisher_line,
                           paired_difference, tests)
from .stages import LATE_RATE, UNJAM_PRESSURE, phi_end, stage_figures, stage_list

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


def _phi_cell(r: dict | None) -> str:
    """phi_J, or for a capped search "≥ phi" at the cap (phi only grows during MLS, so it bounds phi_J)."""
    if r is None:
        return "–"
    if r["phi_J"] is not None:
        return f"{r['phi_J']:.5f}"
    phi = phi_end(r)
    return "–" if phi is None else f"≥ {phi:.5f}"


def summarize(out: Path) -> None:
    by_protocol: dict[str, list[tuple[str, list]]] = {}  # "sigma0.3-ls0.5" -> [(cell, its complete pairs)]
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
                if r is None or not stage_list(r):
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
            traced = [r for r in rs if stage_list(r)]
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
        print("- phi_J paired difference: "
              + paired_difference([o["phi_J"] for o, _ in complete], [c["phi_J"] for _, c in complete]))
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
        by_protocol.setdefault(cell.name.partition("-")[2], []).append((cell.name, complete))
    for protocol, cells in by_protocol.items():
        if len(cells) < 2:
            continue
        pooled = [pair for _, complete in cells for pair in complete]
        # the question of a cell, asked of every N at once: a code difference that does not depend on N
        print(f"\n## {protocol}, pooled over {', '.join(name for name, _ in cells)}\n")
        print("- phi_J paired difference: "
              + paired_difference([o["phi_J"] for o, _ in pooled], [c["phi_J"] for _, c in pooled]))
