"""Tables 2-4 of the paper from the results dataset, written as CSV, Markdown and LaTeX.

* Table 2: phi_GCP from cubic fits (:mod:`spherejam.fits`) of four curves (LS/FB x initial phi / densified
  phi_J) per sigma > 0.
* Table 3: min and max of phi_J over fast compressions (LS 1/gamma < 5, FB 1/gamma < 10^3 by default).
* Table 4: phi_LT = mean of the two minima, phi_RCP = mean of the two maxima, phi_GCP = mean of the four Table 2
  entries (for sigma = 0 the conventional value 0.65, as in the paper).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from .atomic import atomic_output
from .dataset import dataset_config
from .errors import InputError
from .fits import N_COEFFICIENTS, fit_gcp

#: Table 2 rows: (label, protocol, variable, config key of the number of slowest points).
TABLE2_ROWS = (
    ("LS, initial", "ls", "phi", "ls_initial"),
    ("FB, initial", "fb", "phi", "fb_initial"),
    ("LS, densified", "ls", "phi_J", "ls_densified"),
    ("FB, densified", "fb", "phi_J", "fb_densified"),
)
FIT_DEFAULTS = {"ls_initial": 125, "ls_densified": 80, "fb_initial": 300, "fb_densified": 300, "confidence": 0.95}
FAST_DEFAULTS = {"ls_max_inverse_rate": 5.0, "fb_max_inverse_rate": 1000.0}


def _frame(ds) -> pd.DataFrame:
    cols = ["protocol", "sigma", "rate", "inverse_rate", "replica"]
    df = pd.DataFrame({c: ds[c].values for c in cols})
    for name in ("phi", "phi_J"):
        df[name] = ds[name].values if name in ds else np.nan
    df["phi_J"] = completed_phi_J(ds) if "phi_J" in ds else np.nan
    return df


def completed_phi_J(ds) -> np.ndarray:
    """phi_J with NaN where the MLS run was cut by a wall-time limit (``mls_completed`` = 0)."""
    phi_j = ds["phi_J"].values.astype(float).copy()
    if "mls_completed" in ds:
        phi_j[ds["mls_completed"].values != 1] = np.nan
    return phi_j


def table2(ds) -> pd.DataFrame:
    """Long-format Table 2: one row per (curve, sigma > 0) with phi_GCP, half-width, points used."""
    cfg = {**FIT_DEFAULTS, **dataset_config(ds).get("fits", {})}
    df = _frame(ds)
    rows = []
    for label, protocol, var, key in TABLE2_ROWS:
        for sigma in sorted(df.sigma.unique()):
            if sigma == 0:
                continue  # the paper does not fit sigma = 0 (crystallisation); Table 4 takes 0.65
            sub = df[(df.protocol == protocol) & (df.sigma == sigma)]
            row = {"curve": label, "protocol": protocol, "variable": var, "sigma": sigma}
            try:
                fit = fit_gcp(sub.rate.values, sub[var].values, int(cfg[key]), float(cfg["confidence"]))
                c = fit.coefficients
                row.update(
                    phi_gcp=fit.phi_gcp, half_width=fit.half_width, n_points=fit.n_points,
                    min_inverse_rate=fit.min_inverse_rate, c0=c[0], c1=c[1], c2=c[2], c3=c[3],
                )
            except InputError:
                row.update(phi_gcp=math.nan, half_width=math.nan, n_points=int(np.isfinite(sub[var]).sum()))
            rows.append(row)
    return pd.DataFrame(rows)


def table3(ds) -> pd.DataFrame:
    """Per sigma and protocol: min and max phi_J over fast compressions, and how many packings."""
    cfg = {**FAST_DEFAULTS, **dataset_config(ds).get("fast", {})}
    df = _frame(ds)
    rows = []
    for sigma in sorted(df.sigma.unique()):
        row = {"sigma": sigma}
        for protocol in ("ls", "fb"):
            limit = cfg[f"{protocol}_max_inverse_rate"]
            fast = df[(df.protocol == protocol) & (df.sigma == sigma) & (df.inverse_rate < limit)].phi_J.dropna()
            row[f"{protocol}_phi_min_fast"] = fast.min() if len(fast) else math.nan
            row[f"{protocol}_phi_max_fast"] = fast.max() if len(fast) else math.nan
            row[f"{protocol}_n_fast"] = len(fast)
        rows.append(row)
    return pd.DataFrame(rows)


def table4(ds, t2: pd.DataFrame | None = None, t3: pd.DataFrame | None = None) -> pd.DataFrame:
    """phi_LT, phi_RCP and phi_GCP per sigma."""
    t2 = table2(ds) if t2 is None else t2
    t3 = table3(ds) if t3 is None else t3
    gcp0 = float(dataset_config(ds).get("gcp_monodisperse", 0.65))
    rows = []
    for _, r in t3.iterrows():
        sigma = r.sigma
        if sigma == 0:
            gcp, n_fits = gcp0, 0
        else:
            vals = t2[t2.sigma == sigma].phi_gcp.dropna()
            gcp, n_fits = (vals.mean() if len(vals) else math.nan), len(vals)
        rows.append({
            "sigma": sigma,
            "phi_LT": np.nanmean([r.ls_phi_min_fast, r.fb_phi_min_fast]) if r.ls_n_fast + r.fb_n_fast else math.nan,
            "phi_RCP": np.nanmean([r.ls_phi_max_fast, r.fb_phi_max_fast]) if r.ls_n_fast + r.fb_n_fast else math.nan,
            "phi_GCP": gcp,
            "gcp_fits_averaged": n_fits,
        })
    return pd.DataFrame(rows)


def _fmt(x, digits=4) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def _pm(value, half) -> str:
    if math.isnan(value):
        return "–"
    return f"{value:.4f} ± {half:.2e}" if not math.isnan(half) else f"{value:.4f}"


def formatted(name: str, t: pd.DataFrame) -> pd.DataFrame:
    """The human-readable wide layout of a table (as in the paper)."""
    if name == "table2":
        t = t.copy()
        t["cell"] = [_pm(v, h) for v, h in zip(t.phi_gcp, t.half_width)]
        wide = t.pivot(index="curve", columns="sigma", values="cell")
        wide = wide.reindex([r[0] for r in TABLE2_ROWS])
        wide.columns = [f"σ = {s:g}" for s in wide.columns]
        return wide
    if name == "table3":
        out = pd.DataFrame({"σ": [f"{s:g}" for s in t.sigma]})
        for p in ("ls", "fb"):
            out[f"{p.upper()} φ_min^fast"] = [_fmt(x) for x in t[f"{p}_phi_min_fast"]]
            out[f"{p.upper()} φ_max^fast"] = [_fmt(x) for x in t[f"{p}_phi_max_fast"]]
            out[f"{p.upper()} n"] = t[f"{p}_n_fast"].astype(int)
        return out.set_index("σ")
    if name == "table4":
        out = pd.DataFrame({"σ": [f"{s:g}" for s in t.sigma]})
        for col in ("phi_LT", "phi_RCP", "phi_GCP"):
            out[col.replace("phi_", "φ_")] = [_fmt(x) for x in t[col]]
        return out.set_index("σ")
    raise InputError(f"table={name!r}: must be table2, table3 or table4")


def _tex(text) -> str:
    for plain, tex in (("_", r"\_"), ("σ", r"$\sigma$"), ("φ", r"$\varphi$"), ("±", r"$\pm$")):
        text = str(text).replace(plain, tex)
    return text


def _latex(df: pd.DataFrame, caption: str) -> str:
    cols = list(df.columns)
    lines = [r"\begin{table}", r"\centering", f"\\caption{{{caption}}}", r"\begin{tabular}{l" + "c" * len(cols) + "}",
             r"\hline", " & ".join([_tex(df.index.name or "")] + [_tex(c) for c in cols]) + r" \\", r"\hline"]
    for idx, row in df.iterrows():
        lines.append(" & ".join([_tex(idx)] + [_tex(v) for v in row.values]) + r" \\")
    lines += [r"\hline", r"\end{tabular}", r"\end{table}"]
    return "\n".join(lines) + "\n"


def _markdown(df: pd.DataFrame, caption: str) -> str:
    cols = [df.index.name or ""] + [str(c) for c in df.columns]
    lines = [f"**{caption}**", "", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for idx, row in df.iterrows():
        lines.append("| " + " | ".join([str(idx)] + [str(v) for v in row.values]) + " |")
    return "\n".join(lines) + "\n"


CAPTIONS = {
    "table2": "Table 2: GCP limits phi_GCP = c0 of cubic fits in sqrt(gamma) with 95% confidence half-widths",
    "table3": "Table 3: min and max closest jamming densities of fast compressions",
    "table4": "Table 4: lowest typical (LT), RCP and GCP densities",
}


def compute_tables(ds) -> dict[str, pd.DataFrame]:
    t2, t3 = table2(ds), table3(ds)
    return {"table2": t2, "table3": t3, "table4": table4(ds, t2, t3)}


#: The files :func:`write_tables` writes into its folder.
TABLE_FILES = tuple(f"{name}.{ext}" for name in ("table2", "table3", "table4") for ext in ("csv", "md", "tex"))


def write_tables(ds, outdir: str | os.PathLike) -> list[Path]:
    """Write every table as ``<name>.csv`` (machine-readable, long), ``.md`` and ``.tex`` (paper layout)."""
    outdir = Path(outdir)
    written = []
    for name, t in compute_tables(ds).items():
        wide = formatted(name, t)
        for ext, text in (
            ("csv", t.to_csv(index=False, float_format="%.10g")),
            ("md", _markdown(wide, CAPTIONS[name])),
            ("tex", _latex(wide, CAPTIONS[name])),
        ):
            path = outdir / f"{name}.{ext}"
            with atomic_output(path, f".{ext}") as tmp:
                Path(tmp).write_text(text)
            written.append(path)
    return written


__all__ = ["table2", "table3", "table4", "compute_tables", "write_tables", "N_COEFFICIENTS"]
