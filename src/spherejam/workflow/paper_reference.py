"""The paper's Tables 2, 3 and 4 (Baranau & Tallarek, Soft Matter 2014) as reference data.

Every cell is copied as printed; ``source`` names the table, row and column it came from. The text of the paper
this project works from has lost some cells:

* Table 3 keeps only one of its two phi_min^fast rows (LS and FB), and the text does not say which one. Both
  protocols' ``phi_min`` are therefore missing (NaN); the surviving row is available, without a protocol, from
  :func:`table3_min_unattributed`. (The paper states that the LS and FB minima differ by <= 1e-3.)
* Table 4 keeps phi_LT only for sigma = 0, 0.15 and 0.25, and phi_GCP only for sigma = 0, 0.15 and 0.25.

A lost cell is filled only where the paper's own rule recomputes it from printed cells, and is then flagged as
derived: Table 4's phi_GCP is "obtained by averaging columns in Table 2" (the mean of the four Table 2 entries).
phi_LT would be the mean of the LS and FB phi_min^fast, but one of the two is lost, so the lost phi_LT cells stay
missing. Every phi_RCP cell of Table 4 survives (each is the rounded mean of the two Table 3 maxima).

The paper's own rule does not reproduce every printed cell to the last digit: at sigma = 0.15 the four Table 2
entries average to 0.66045, Table 4 prints 0.6606. Printed cells are kept as printed.

Densities phi are volume fractions (dimensionless); sigma is the standard deviation of the log-normal sphere
radii distribution (dimensionless, relative to the mean radius); N = 10^4 spheres in the paper.
"""

from __future__ import annotations

import math

import pandas as pd

CITATION = (
    "V. Baranau and U. Tallarek, \"Random-close packing limits for monodisperse and polydisperse hard spheres\", "
    "Soft Matter 10, 3826-3841 (2014), doi:10.1039/c3sm52959b"
)

#: The paper's number of spheres per packing.
PAPER_N = 10_000
#: The paper's fast packings per sigma behind each Table 3 band (its sample sizes for eq. 17's min and max).
FAST_SAMPLE_SIZES = {"ls": 85, "fb": 165}

#: Table 2 methods, in the paper's row order.
TABLE2_METHODS = ("LS, initial", "FB, initial", "LS, densified", "FB, densified")
TABLE2_SIGMAS = (0.05, 0.1, 0.15, 0.2, 0.25, 0.3)
TABLE34_SIGMAS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3)

# Table 2: (phi_GCP, 95 % confidence half-width) per method, columns sigma = 0.05 ... 0.3, as printed.
_TABLE2 = {
    "LS, initial": (
        (0.6528, 1.8489e-4), (0.6557, 1.955e-4), (0.6600, 2.2824e-4),
        (0.6650, 2.8891e-4), (0.6711, 3.4862e-4), (0.6777, 4.5487e-4),
    ),
    "FB, initial": (
        (0.6528, 1.4523e-3), (0.6540, 1.9576e-3), (0.6608, 1.9004e-3),
        (0.6650, 1.7833e-3), (0.6711, 3.0192e-3), (0.6790, 3.8918e-3),
    ),
    "LS, densified": (
        (0.6530, 3.5721e-4), (0.6561, 3.4474e-4), (0.6607, 3.8526e-4),
        (0.6658, 5.2342e-4), (0.6716, 6.517e-4), (0.6786, 9.4406e-4),
    ),
    "FB, densified": (
        (0.6519, 1.5772e-4), (0.6556, 1.9659e-4), (0.6603, 2.4266e-4),
        (0.6658, 3.0977e-4), (0.6725, 4.2419e-4), (0.6787, 5.0797e-4),
    ),
}

# Table 3, columns sigma = 0.0 ... 0.3. The phi_max row prints two values per column, LS (upper) then FB;
# their means are Table 4's phi_RCP, which confirms the pairing.
_TABLE3_MAX = {
    "LS": (0.6406, 0.6414, 0.6437, 0.6485, 0.6536, 0.6599, 0.6675),
    "FB": (0.6404, 0.6428, 0.6443, 0.6487, 0.6547, 0.6601, 0.6676),
}
# The one surviving phi_min^fast row (LS or FB, not recoverable from the text).
_TABLE3_MIN_UNATTRIBUTED = (0.6356, 0.6364, 0.6388, 0.6428, 0.6469, 0.6540, 0.6593)

_NAN = math.nan
# Table 4 as printed, columns sigma = 0.0 ... 0.3; NaN = lost in the text.
_TABLE4_PRINTED = {
    "phi_LT": (0.6353, _NAN, _NAN, 0.6426, _NAN, 0.6541, _NAN),
    "phi_RCP": (0.6405, 0.6421, 0.6440, 0.6486, 0.6542, 0.6600, 0.6676),
    # sigma = 0: "taken at a conventional value of 0.65" (not fitted; Table 2 has no sigma = 0 column).
    "phi_GCP": (0.65, _NAN, _NAN, 0.6606, _NAN, 0.6716, _NAN),
}


def table2() -> pd.DataFrame:
    """Table 2: phi_GCP and its 95 % confidence half-width per sigma (0.05-0.3) and method.

    Columns ``sigma``, ``method`` (one of :data:`TABLE2_METHODS`), ``phi_GCP``, ``ci_half_width``, ``source``.
    """
    rows = []
    for method in TABLE2_METHODS:
        for sigma, (phi, half) in zip(TABLE2_SIGMAS, _TABLE2[method]):
            rows.append({
                "sigma": sigma, "method": method, "phi_GCP": phi, "ci_half_width": half,
                "source": f"Table 2, row '{method}', column sigma = {sigma:g}",
            })
    return pd.DataFrame(rows)


def table3() -> pd.DataFrame:
    """Table 3: phi_min^fast and phi_max^fast per sigma (0-0.3) and protocol ("LS", "FB").

    ``phi_min`` is NaN for both protocols (see the module docstring and :func:`table3_min_unattributed`).
    """
    rows = []
    for protocol in ("LS", "FB"):
        for sigma, phi_max in zip(TABLE34_SIGMAS, _TABLE3_MAX[protocol]):
            rows.append({
                "sigma": sigma, "protocol": protocol, "phi_min": _NAN, "phi_max": phi_max,
                "source": (f"Table 3, column sigma = {sigma:g}: phi_max^fast row '{protocol}' as printed; "
                           f"phi_min^fast row '{protocol}' lost in the text"),
            })
    return pd.DataFrame(rows)


def table3_min_unattributed() -> pd.DataFrame:
    """The surviving phi_min^fast row of Table 3: ``sigma``, ``phi_min``, ``source``; its protocol is unknown."""
    return pd.DataFrame({
        "sigma": list(TABLE34_SIGMAS),
        "phi_min": list(_TABLE3_MIN_UNATTRIBUTED),
        "source": [f"Table 3, the surviving phi_min^fast row (LS or FB), column sigma = {s:g}"
                   for s in TABLE34_SIGMAS],
    })


def table4() -> pd.DataFrame:
    """Table 4 indexed by ``sigma``: ``phi_LT``, ``phi_RCP``, ``phi_GCP`` and ``*_derived`` flags.

    A derived cell was lost in the text and recomputed by the paper's rule: phi_GCP = mean of the four Table 2
    entries of that sigma. Cells neither printed nor derivable are NaN.
    """
    t2 = table2()
    out = pd.DataFrame(index=pd.Index([float(s) for s in TABLE34_SIGMAS], name="sigma"))
    for col, values in _TABLE4_PRINTED.items():
        out[col] = [float(v) for v in values]
        out[f"{col}_derived"] = False
    for sigma in out.index:
        if math.isnan(out.at[sigma, "phi_GCP"]):
            vals = t2[t2.sigma == sigma].phi_GCP
            if len(vals) == len(TABLE2_METHODS):
                out.at[sigma, "phi_GCP"] = float(vals.mean())
                out.at[sigma, "phi_GCP_derived"] = True
    return out[["phi_LT", "phi_RCP", "phi_GCP", "phi_LT_derived", "phi_RCP_derived", "phi_GCP_derived"]]


__all__ = ["CITATION", "TABLE2_METHODS", "table2", "table3", "table3_min_unattributed", "table4"]
