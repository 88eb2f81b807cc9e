"""``spherejam psd SPEC``: a size distribution's descriptors and the published phi_RCP models, in about a second."""

from __future__ import annotations

import json
import math

from ..core.validation import FIELDS, UNIT_OPEN
from . import seed_int

#: Lowest jamming density at which the box side of a sample is estimated (a typical monodisperse phi_J); a
#: polydisperse distribution's box is estimated at its Farr-Groot phi_RCP (:func:`box_phi`): a denser packing has
#: a smaller box.
PHI_BOX = 0.64


def register(sub) -> None:
    p = sub.add_parser("psd", help="descriptors of a size distribution and the phi_RCP models (docs/psd.md)",
                       description="Descriptors (delta, skewness S, d_max/d_min, M1-M3, z) of a size distribution "
                       "and the instant phi_RCP estimates of Farr-Groot, Desmond-Weeks and Santos et al. SPEC as "
                       "for `spherejam seed --psd`.")
    p.add_argument("spec", metavar="SPEC", help="e.g. gaussian:delta=0.2, table:powder.csv (docs/psd.md)")
    p.add_argument("--n", type=FIELDS["n"].arg, default=None,
                   help="also draw a sample of N spheres: its descriptors and the box it needs")
    p.add_argument("--seed", type=seed_int, default=0, help="seed of the sample (default 0)")
    p.add_argument("--phi-mono", type=UNIT_OPEN.arg, default=None,
                   help="monodisperse phi_RCP for the Santos et al. model (default: the paper's 0.6405; give ours)")
    p.add_argument("--json", action="store_true", help="print machine-readable JSON")
    p.set_defaults(func=_psd)


def box_phi(dist) -> float:
    """The packing fraction at which a distribution's box is checked against CALiPPSO's limit: its Farr-Groot
    phi_RCP, at least PHI_BOX."""
    from ..analysis.farr_groot import phi_rcp_distribution

    return max(PHI_BOX, float(phi_rcp_distribution(dist)))


def box_side(diameters, phi: float = PHI_BOX) -> float:
    """Side L of the periodic cube in which mean-1 ``diameters`` fill the packing fraction ``phi``."""
    return (len(diameters) * math.pi / 6 * float((diameters**3).mean()) / phi) ** (1 / 3)


def describe(spec: str, n: int | None = None, seed: int = 0, phi_mono: float | None = None) -> dict:
    """Everything ``spherejam psd`` prints, as a dict."""
    from ..analysis.psd_models import predictions
    from ..core.errors import InputError
    from ..core.seeding import rng_for
    from ..core.size_distribution import parse, sample_descriptors

    dist = parse(spec, "SPEC")
    out = {"spec": dist.spec, "family": dist.family, "normalisation": "number-mean diameter <D> = 1",
           "population": dist.descriptors().as_dict(), "source": dist.provenance()}
    if dist.fixed_n is not None:
        if n is not None and n != dist.fixed_n:
            raise InputError(f"--n={n}: {dist.spec} holds {dist.fixed_n} diameters (leave out --n)")
        n = dist.fixed_n
    if n is not None:
        d = dist.draw(n, rng_for(seed))
        phi = box_phi(dist)
        box = box_side(d, phi)
        out["sample"] = {"n": int(n), "seed": int(seed), **sample_descriptors(d).as_dict(),
                         "box_at_phi": phi, "box": box, "box_over_dmax": box / float(d.max())}
    out["models"] = [{"model": p.model, "phi_rcp": p.phi, "in_range": p.in_range, "validity": p.note,
                      "citation": p.citation} for p in predictions(dist, phi_mono)]
    return out


_NAMES = {"farr_groot": "Farr–Groot", "desmond_weeks": "Desmond–Weeks", "santos": "Santos et al."}


def _line(d: dict) -> str:
    ratio = d["size_ratio"]
    return (f"δ = {d['delta']:.4f}   S = {d['skewness']:+.4f}   d_max/d_min = "
            f"{'unbounded' if not math.isfinite(ratio) else format(ratio, '.4g')}   M1 = {d['m1']:.4g}   "
            f"M2 = {d['m2']:.5g}   M3 = {d['m3']:.5g}   z = M2²/(M1·M3) = {d['z']:.5f}")


def _psd(args) -> int:
    info = describe(args.spec, args.n, args.seed, args.phi_mono)
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    print(f"{info['spec']}   ({info['normalisation']})")
    print(f"  distribution: {_line(info['population'])}")
    if "sample" in info:
        s = info["sample"]
        print(f"  sample (N = {s['n']}, seed {s['seed']}): {_line(s)}")
        print(f"  box at φ = {s['box_at_phi']:.4g}: L = {s['box']:.3g} mean diameters = {s['box_over_dmax']:.3g} d_max")
    print("  φ_RCP models:")
    for m in info["models"]:
        flag = "" if m["in_range"] else "  [outside the stated range]"
        print(f"    {_NAMES[m['model']]:<14} {m['phi_rcp']:.4f}   {m['citation']}; {m['validity']}{flag}")
    return 0
