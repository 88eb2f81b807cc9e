"""Tables 2-4 of the paper from the results dataset, next to the paper's values, written as CSV, Markdown and LaTeX.

* Table 2: phi_GCP from cubic fits (:mod:`spherejam.workflow.fits`) of four curves (LS/FB x initial phi / densified
  phi_J) per sigma > 0. A fit with fewer than ``fits.min_points`` packings, or a confidence half-width above
  ``fits.max_half_width``, is "not estimable (n = ...)": its phi_GCP is NaN and ``status`` says why.
* Table 3: the band edges of phi_J over fast compressions (LS 1/gamma < 5, FB 1/gamma < 10^3 by default), by the
  sample min/max and by the paper's alpha-quantiles (eq. 18), with order-statistic confidence intervals
  (:mod:`spherejam.workflow.bands`). ``bands.method`` chooses which edge Tables 3-4 report; a band of fewer than
  ``bands.min_packings`` packings is not estimable.
* Table 4: phi_LT = mean of the LS and FB low edges, phi_RCP = mean of the high edges, phi_GCP = mean of the Table 2
  entries (for sigma = 0 the conventional value 0.65, as in the paper), and beside phi_RCP the three published
  models of :mod:`spherejam.analysis.psd_models` (Farr-Groot, Desmond-Weeks, Santos et al.) with ours - model.

Rows are per size distribution (the dataset's ``distribution``): the ``sigmas`` in ascending order, then the named
distributions by delta. A dataset with named distributions gets a ``distribution`` column (its key); one with
``sigmas`` only has the columns of spherejam 0.1. The paper's values appear where the paper has that distribution
(a log-normal with one of its sigmas); a monodisperse distribution (delta = 0) is not fitted in Table 2 and takes the
conventional phi_GCP.

Every row whose phi_GCP lies below the run's own phi_RCP (Table 4, and the Table 2 cells) is flagged
(``gcp_below_rcp``): with enough data phi_GCP - phi_RCP ~ 0.01, so it signals too little data, not a result.

Every table carries the paper's value (:mod:`spherejam.workflow.paper_reference`), ours - paper, and that difference
in units of our confidence half-width. The statistics are described in docs/statistics.md.

A dataset with packings at several N (a ladder) gets its rows per N (column ``n``), then rows extrapolated to the
paper's N = 10^4 and to N -> infinity (``extrapolated``; :mod:`spherejam.workflow.finite_size`, docs/finite_size.md):
Table 3's edges predicted for the paper's sample sizes, Table 2's phi_GCP extrapolated per curve, and Table 4 from
those by its own rule. ``finite_size.{csv,md}`` gives the fitted scaling and its leave-the-largest-N-out check.

A dataset with containers (docs/containers.md) gets every table per container (columns ``container`` and
``container_spec`` first), each computed from that container's packings alone, so that phi_LT and phi_RCP in a
cylinder stand beside the bulk ones. The paper's values are those of the bulk: a container other than the periodic
cube has none (NaN), and its finite-size scaling is not fitted (``finite_size`` is of the reference container,
:func:`spherejam.workflow.dataset.reference_packings`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.atomic import atomic_folder
from ..core.errors import InputError
from . import paper_reference
from .bands import BAND_DEFAULTS, FAST_DEFAULTS, band_edges
from . import finite_size
from .dataset import at_n, container_keys, dataset_config, reference_packings, sizes_in, with_distributions
from .fits import FIT_DEFAULTS, GCP_MONODISPERSE, N_COEFFICIENTS, fit_gcp

#: Table 2 rows: (label, protocol, variable, config key of the number of slowest points).
TABLE2_ROWS = (
    ("LS, initial", "ls", "phi", "ls_initial"),
    ("FB, initial", "fb", "phi", "fb_initial"),
    ("LS, densified", "ls", "phi_J", "ls_densified"),
    ("FB, densified", "fb", "phi_J", "fb_densified"),
)
#: Columns of an empty Table 2 (an experiment with sigma = 0 only).
TABLE2_COLUMNS = ["curve", "protocol", "variable", "sigma", "phi_gcp", "half_width", "status", "n_points",
                  "paper_phi_gcp", "paper_half_width", "minus_paper", "minus_paper_in_half_widths"]


def _frame(ds) -> pd.DataFrame:
    ds = with_distributions(ds)
    cols = ["protocol", "sigma", "rate", "inverse_rate", "replica", "distribution", "psd", "psd_delta"]
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


def fit_settings(ds) -> dict:
    return {**FIT_DEFAULTS, **dataset_config(ds).get("fits", {})}


def band_settings(ds) -> dict:
    return {**BAND_DEFAULTS, **dataset_config(ds).get("bands", {})}


def _groups(df: pd.DataFrame) -> list[dict]:
    """The table rows' distributions in order (``sigmas`` ascending, then named ones as they come), each with its
    key, sigma (NaN if named), the paper's sigma (NaN where the paper has no such distribution) and delta."""
    from ..core.size_distribution import parse

    groups = {}
    for key, sigma, spec, delta in zip(df.distribution, df.sigma, df.psd, df.psd_delta):
        if key in groups:
            continue
        paper_sigma = float(sigma)
        if not math.isfinite(paper_sigma) and str(spec).startswith("lognormal:"):
            paper_sigma = float(parse(spec).sigma)
        groups[key] = {"distribution": key, "sigma": float(sigma), "paper_sigma": paper_sigma,
                       "delta": float(delta), "psd": str(spec)}
    # sigmas by sigma, then named ones by delta and name (the manifest stores the config with sorted keys, so the
    # config's own order is not known here)
    return sorted(groups.values(), key=lambda g: (not math.isfinite(g["sigma"]),
                                                 g["sigma"] if math.isfinite(g["sigma"]) else g["delta"],
                                                 g["distribution"]))


def _has_named(df: pd.DataFrame) -> bool:
    return not bool(np.all(np.isfinite(df.sigma.values.astype(float))))


def _start(group: dict, named: bool) -> dict:
    """The first cells of a row: ``sigma`` (and with named distributions, ``distribution`` and ``psd`` first)."""
    return {"distribution": group["distribution"], "psd": group["psd"], "sigma": group["sigma"]} if named else {
        "sigma": group["sigma"]}


def not_estimable(n: int, why: str = "") -> str:
    return f"not estimable (n = {n}{', ' + why if why else ''})"


#: Table 2's status where a distribution has no slow packings at an N (a config may have a slow series at some N
#: only, as the reproduction ladder: none at N = 500): nothing is fitted, the fast packings are no slow series.
NO_SLOW_SERIES = "no slow series at this N"
#: Where a value is the paper's rather than ours (the monodisperse phi_GCP): said in its cell, with no difference.
TAKEN_FROM_PAPER = "taken from the paper, not measured"


def paper_row(frame: pd.DataFrame, sigma: float, **match) -> pd.Series | None:
    sel = np.isclose(frame.sigma.values.astype(float), sigma)
    for key, value in match.items():
        sel &= frame[key].values == value
    rows = frame[sel]
    return rows.iloc[0] if len(rows) else None


def _compare(ours: float, half_width: float, paper: float) -> tuple[float, float]:
    """(ours - paper, (ours - paper) / half-width); NaN where a term is missing or the half-width is not positive."""
    diff = ours - paper if math.isfinite(ours) and math.isfinite(paper) else math.nan
    ratio = diff / half_width if math.isfinite(diff) and math.isfinite(half_width) and half_width > 0 else math.nan
    return diff, ratio


def table2(ds) -> pd.DataFrame:
    """Long-format Table 2: one row per (curve, sigma > 0) with phi_GCP, half-width, points used, the paper's value."""
    cfg = fit_settings(ds)
    min_points = max(int(cfg["min_points"]), N_COEFFICIENTS + 1)
    max_half = cfg.get("max_half_width")
    paper = paper_reference.table2()
    fast = {**FAST_DEFAULTS, **dataset_config(ds).get("fast", {})}
    df = _frame(ds)
    named = _has_named(df)
    rows = []
    for label, protocol, var, key in TABLE2_ROWS:
        for group in _groups(df):
            if group["delta"] == 0:
                continue  # the paper does not fit sigma = 0 (crystallisation); Table 4 takes 0.65
            # the slow series only: a fast packing (Table 3's band) is not a point of the extrapolation to gamma -> 0
            sub = df[(df.protocol == protocol) & (df.distribution == group["distribution"])
                     & (df.inverse_rate >= fast[f"{protocol}_max_inverse_rate"])]
            row = {"curve": label, "protocol": protocol, "variable": var, **_start(group, named),
                   "phi_gcp": math.nan, "half_width": math.nan, "status": ""}
            n_avail = int(np.isfinite(sub[var]).sum())
            if n_avail == 0:
                row.update(n_points=0, status=NO_SLOW_SERIES)
            else:
                _fit_row(row, sub.rate.values, sub[var].values, int(cfg[key]), float(cfg["confidence"]), min_points,
                         max_half, n_avail)
            ref = paper_row(paper, group["paper_sigma"], method=label)
            row["paper_phi_gcp"] = float(ref.phi_GCP) if ref is not None else math.nan
            row["paper_half_width"] = float(ref.ci_half_width) if ref is not None else math.nan
            row["minus_paper"], row["minus_paper_in_half_widths"] = _compare(
                row["phi_gcp"], row["half_width"], row["paper_phi_gcp"])
            rows.append(row)
    out = pd.DataFrame(rows, columns=TABLE2_COLUMNS) if not rows else pd.DataFrame(rows)
    out["estimable"] = out.status == ""
    return out


def _fit_row(row: dict, rate, phi, n_slowest: int, confidence: float, min_points: int, max_half, n_avail: int
             ) -> None:
    """One Table 2 cell: the cubic fit of the slowest ``n_slowest`` packings, or why it is not estimable."""
    try:
        fit = fit_gcp(rate, phi, n_slowest, confidence)
    except InputError:
        row.update(n_points=n_avail, status=not_estimable(n_avail))
        return
    c = fit.coefficients
    row.update(
        n_points=fit.n_points, min_inverse_rate=fit.min_inverse_rate, c0=c[0], c1=c[1], c2=c[2], c3=c[3],
        phi_gcp_fit=fit.phi_gcp, half_width_fit=fit.half_width,
    )
    if fit.n_points < min_points:
        row["status"] = not_estimable(fit.n_points, f"fewer than {min_points} points")
    elif not math.isfinite(fit.half_width):
        row["status"] = not_estimable(fit.n_points, "no confidence interval")
    elif max_half is not None and fit.half_width > float(max_half):
        row["status"] = not_estimable(fit.n_points, f"half-width {fit.half_width:.2g} > {max_half:g}")
    else:
        row.update(phi_gcp=fit.phi_gcp, half_width=fit.half_width)


def table3(ds) -> pd.DataFrame:
    """Per sigma and protocol: the band of phi_J over fast compressions (min/max, alpha-quantiles with intervals),
    the edge ``bands.method`` reports, and the paper's values."""
    cfg = {**FAST_DEFAULTS, **dataset_config(ds).get("fast", {})}
    bands = band_settings(ds)
    method, alpha, conf = bands["method"], float(bands["alpha"]), float(bands["confidence"])
    paper = paper_reference.table3()
    paper_min = paper_reference.table3_min_unattributed()
    df = _frame(ds)
    named = _has_named(df)
    rows = []
    for group in _groups(df):
        row = _start(group, named)
        sigma = group["paper_sigma"]
        for protocol in ("ls", "fb"):
            limit = cfg[f"{protocol}_max_inverse_rate"]
            fast = df[(df.protocol == protocol) & (df.distribution == group["distribution"])
                      & (df.inverse_rate < limit)].phi_J.dropna()
            e = band_edges(fast.values, alpha, conf)
            p = f"{protocol}_"
            row[p + "n_fast"] = e.n
            row[p + "phi_min_fast"] = e.phi_min
            row[p + "phi_max_fast"] = e.phi_max
            row[p + "phi_low_quantile"], (row[p + "phi_low_ci_low"], row[p + "phi_low_ci_high"]) = e.q_low, e.q_low_ci
            row[p + "phi_high_quantile"], (row[p + "phi_high_ci_low"], row[p + "phi_high_ci_high"]) = (
                e.q_high, e.q_high_ci)
            ok = e.n >= int(bands["min_packings"])
            row[p + "status"] = "" if ok else not_estimable(e.n, f"fewer than {int(bands['min_packings'])} packings")
            ref = paper_row(paper, sigma, protocol=protocol.upper())
            ref_min = paper_row(paper_min, sigma)
            for side, paper_value in (
                ("low", float(ref_min.phi_min) if ref_min is not None else math.nan),  # protocol unknown
                ("high", float(ref.phi_max) if ref is not None else math.nan),
            ):
                value, half = e.edge(side, method) if ok else (math.nan, math.nan)
                row[f"{p}phi_{side}"], row[f"{p}phi_{side}_half_width"] = value, half
                row[f"{p}phi_{side}_paper"] = paper_value
                row[f"{p}phi_{side}_minus_paper"], row[f"{p}phi_{side}_minus_paper_in_half_widths"] = _compare(
                    value, half, paper_value)
        rows.append(row)
    out = pd.DataFrame(rows)
    out.attrs["method"] = method
    return out


def _mean_with_half_width(pairs) -> tuple[float, float, int]:
    """Mean of the finite estimates, and its half-width from theirs in quadrature (NaN if any is missing)."""
    pairs = [(v, h) for v, h in pairs if math.isfinite(v)]
    if not pairs:
        return math.nan, math.nan, 0
    values, halves = zip(*pairs)
    half = math.sqrt(sum(h * h for h in halves)) / len(halves) if all(math.isfinite(h) for h in halves) else math.nan
    return float(np.mean(values)), half, len(pairs)


def table4(ds, t2: pd.DataFrame | None = None, t3: pd.DataFrame | None = None) -> pd.DataFrame:
    """phi_LT, phi_RCP and phi_GCP per sigma with half-widths, the paper's values and the GCP < RCP flag."""
    t2 = table2(ds) if t2 is None else t2
    t3 = table3(ds) if t3 is None else t3
    gcp0 = float(dataset_config(ds).get("gcp_monodisperse", GCP_MONODISPERSE))
    paper = paper_reference.table4()
    df = _frame(ds)
    named = _has_named(df)
    groups = {g["distribution"]: g for g in _groups(df)}
    rows = []
    for _, r in t3.iterrows():
        group = groups[r.distribution] if named else next(g for g in groups.values() if g["sigma"] == r.sigma)
        sigma, mono = group["paper_sigma"], group["delta"] == 0
        row = _start(group, named)
        for col, side in (("phi_LT", "low"), ("phi_RCP", "high")):
            row[col], row[f"{col}_half_width"], _ = _mean_with_half_width(
                [(r[f"ls_phi_{side}"], r[f"ls_phi_{side}_half_width"]),
                 (r[f"fb_phi_{side}"], r[f"fb_phi_{side}_half_width"])])
        if mono:
            row["phi_GCP"], row["phi_GCP_half_width"], n_fits = gcp0, math.nan, 0
        else:
            key = "distribution" if named else "sigma"
            cells = t2[t2[key] == row[key]] if len(t2) else t2
            row["phi_GCP"], row["phi_GCP_half_width"], n_fits = _mean_with_half_width(
                zip(cells.phi_gcp, cells.half_width)) if len(cells) else (math.nan, math.nan, 0)
        row["gcp_fits_averaged"] = n_fits
        row["phi_GCP_source"] = "paper" if mono else "measured"  # the monodisperse phi_GCP is the paper's constant
        row["gcp_below_rcp"] = bool(not mono and row["phi_GCP"] < row["phi_RCP"])
        match = paper.index[np.isclose(paper.index.values, sigma)]
        for col in ("phi_LT", "phi_RCP", "phi_GCP"):
            ref = paper.loc[match[0]] if len(match) else None
            row[f"{col}_paper"] = float(ref[col]) if ref is not None else math.nan
            row[f"{col}_paper_derived"] = bool(ref[f"{col}_derived"]) if ref is not None else False
            row[f"{col}_minus_paper"], row[f"{col}_minus_paper_in_half_widths"] = _compare(
                row[col], row[f"{col}_half_width"], row[f"{col}_paper"])
        if mono:  # no difference between the paper's value and itself
            row["phi_GCP_minus_paper"] = row["phi_GCP_minus_paper_in_half_widths"] = math.nan
        row["_psd"] = group["psd"]
        rows.append(row)
    return _with_models(pd.DataFrame(rows))


#: Table 4's model columns: model name -> column prefix.
MODELS = {"farr_groot": "Farr–Groot", "desmond_weeks": "Desmond–Weeks", "santos": "Santos et al."}


def _with_models(t4: pd.DataFrame) -> pd.DataFrame:
    """Table 4 with the published phi_RCP models beside ours (``model_<name>``, ``phi_RCP_minus_<name>``).
    Santos et al.'s one input, the monodisperse phi_RCP, is ours where a delta = 0 row has one, else the paper's."""
    from ..analysis.psd_models import PHI_RCP_MONO_PAPER, predictions

    if t4.empty:
        return t4
    mono = [v for v, spec in zip(t4.phi_RCP, t4._psd) if math.isfinite(v) and _is_mono(spec)]
    phi_mono = mono[0] if mono else PHI_RCP_MONO_PAPER
    cols = {f"model_{m}": [] for m in MODELS}
    for spec in t4._psd:
        for p in predictions(spec, phi_mono):
            cols[f"model_{p.model}"].append(p.phi)
    out = t4.drop(columns="_psd")
    for m in MODELS:
        out[f"model_{m}"] = cols[f"model_{m}"]
        out[f"phi_RCP_minus_{m}"] = out.phi_RCP - out[f"model_{m}"]
    out["santos_phi_mono"] = phi_mono
    out.attrs["santos_input"] = "ours (delta = 0 row)" if mono else "the paper's 0.6405 (no monodisperse row of ours)"
    return out


def _is_mono(spec: str) -> bool:
    from ..core.size_distribution import parse

    return parse(spec).descriptors().delta == 0


def _flag_table2(t2: pd.DataFrame, t4: pd.DataFrame) -> pd.DataFrame:
    """Table 2 cells whose phi_GCP lies below the run's phi_RCP of the same sigma."""
    t2 = t2.copy()
    key = "distribution" if "distribution" in t4 else "sigma"
    rcp = dict(zip(t4[key], t4.phi_RCP))
    t2["gcp_below_rcp"] = [bool(g < rcp.get(s, math.nan)) for s, g in zip(t2[key], t2.phi_gcp)] if len(t2) else []
    return t2


# --- human-readable layouts -------------------------------------------------------------------------------------

def _fmt(x, digits=4) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def _signed(x, digits=4) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:+.{digits}f}"


def _ratio(x) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    return f"{x:+.1f}" if abs(x) < 1e3 else f"{x:+.1e}"


def _pm(value, half) -> str:
    if math.isnan(value):
        return "–"
    return f"{value:.4f} ± {half:.2e}" if not math.isnan(half) else f"{value:.4f}"


METHOD_LABELS = {"minmax": "sample min/max", "quantile": "α-quantile"}
GCP_BELOW_RCP = "φ_GCP < φ_RCP: too little data"
PAPER_MIN_NOTE = "paper: the surviving φ_min^fast row of Table 3 (LS or FB, not known which)"


def _label(r) -> str:
    """A row's distribution as the tables show it: sigma for a sigmas-only experiment, else the key."""
    return str(r.distribution) if "distribution" in r.index else f"{r.sigma:g}"


def n_label(n: float, extrapolated: bool = False) -> str:
    """An N as the tables show it: ``1000``, ``10000 (extrapolated)``, ``∞ (extrapolated)``."""
    text = "∞" if math.isinf(n) else f"{int(n)}"
    return f"{text} (extrapolated)" if extrapolated else text


def _n_cells(r) -> dict:
    """The container cell of a row of a table with containers, and the N cell of a row of a table with several N
    (none for one N in the periodic cube, whose tables are those of spherejam 0.1)."""
    cells = {"container": r.container} if "container" in r.index else {}
    return {**cells, "N": n_label(r.n, bool(r.extrapolated))} if "n" in r.index else cells


def formatted(name: str, t: pd.DataFrame, method: str | None = None) -> pd.DataFrame:
    """The human-readable layout of a table, with the paper's value, ours − paper and that in half-widths."""
    idx = "distribution" if "distribution" in t.columns else "σ"
    if name == "table2":
        rows = []
        for _, r in t.iterrows():
            rows.append({
                idx: _label(r), **_n_cells(r), "method": r.curve,
                "φ_GCP (ours)": r.status if r.status else _pm(r.phi_gcp, r.half_width),
                "n": int(r.n_points),
                "paper": _pm(r.paper_phi_gcp, r.paper_half_width),
                "ours − paper": _signed(r.minus_paper),
                "(ours − paper) / half-width": _ratio(r.minus_paper_in_half_widths),
                "flag": GCP_BELOW_RCP if r.get("gcp_below_rcp", False) else "",
            })
        return pd.DataFrame(rows).set_index(idx) if rows else pd.DataFrame()
    if name == "table3":
        method = method or t.attrs.get("method", BAND_DEFAULTS["method"])
        rows = []
        for _, r in t.iterrows():
            for p in ("ls", "fb"):
                for side, edge in (("low", "φ_min^fast"), ("high", "φ_max^fast")):
                    q, lo, hi = (r[f"{p}_phi_{side}_quantile"], r[f"{p}_phi_{side}_ci_low"],
                                 r[f"{p}_phi_{side}_ci_high"])
                    ours = r[f"{p}_status"] or _pm(r[f"{p}_phi_{side}"], r[f"{p}_phi_{side}_half_width"])
                    rows.append({
                        idx: _label(r), **_n_cells(r), "protocol": p.upper(), "edge": edge,
                        "n": int(r[f"{p}_n_fast"]),
                        f"ours ({METHOD_LABELS.get(method, method)})": ours,
                        "sample min/max": _fmt(r[f"{p}_phi_{'min' if side == 'low' else 'max'}_fast"]),
                        "α-quantile [95 % CI]": f"{_fmt(q)} [{_fmt(lo)}, {_fmt(hi)}]",
                        "paper": _fmt(r[f"{p}_phi_{side}_paper"]) + (" †" if side == "low" else ""),
                        "ours − paper": _signed(r[f"{p}_phi_{side}_minus_paper"]),
                        "(ours − paper) / half-width": _ratio(r[f"{p}_phi_{side}_minus_paper_in_half_widths"]),
                    })
        return pd.DataFrame(rows).set_index(idx) if rows else pd.DataFrame()
    if name == "table4":
        rows = []
        for _, r in t.iterrows():
            for col, label in (("phi_LT", "φ_LT"), ("phi_RCP", "φ_RCP"), ("phi_GCP", "φ_GCP")):
                taken = col == "phi_GCP" and _taken_from_paper(r)
                rows.append({
                    idx: _label(r), **_n_cells(r), "quantity": label,
                    "ours": f"{_fmt(r[col])} ({TAKEN_FROM_PAPER})" if taken else _pm(r[col], r[f"{col}_half_width"]),
                    "paper": _fmt(r[f"{col}_paper"]) + (" *" if r[f"{col}_paper_derived"] else ""),
                    "ours − paper": _signed(r[f"{col}_minus_paper"]),
                    "(ours − paper) / half-width": _ratio(r[f"{col}_minus_paper_in_half_widths"]),
                    "flag": GCP_BELOW_RCP if col == "phi_GCP" and r.gcp_below_rcp else "",
                })
        return pd.DataFrame(rows).set_index(idx) if rows else pd.DataFrame()
    raise InputError(f"table={name!r}: must be table2, table3 or table4")


def _taken_from_paper(r) -> bool:
    """The row's phi_GCP is the paper's constant (a monodisperse distribution), not a fit of ours."""
    return r.get("phi_GCP_source", "measured") == "paper"


def _where(r) -> dict:
    where = {"container": r.container} if "container" in r.index else {}
    if "n" in r.index:
        where["n"] = r.n
    if "distribution" in r.index:
        where["distribution"] = r.distribution
    return {**where, "sigma": r.sigma}


def comparison(tables: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """Every cell we can set against the paper, in one long table (the report's "Comparison with the paper")."""
    rows = []
    for _, r in tables["table2"].iterrows():
        rows.append({"table": "Table 2", **_where(r), "row": r.curve, "quantity": "phi_GCP",
                     "ours": r.phi_gcp, "half_width": r.half_width, "paper": r.paper_phi_gcp,
                     "paper_derived": False, "ours_minus_paper": r.minus_paper,
                     "minus_paper_in_half_widths": r.minus_paper_in_half_widths,
                     "note": r.status or (GCP_BELOW_RCP if r.gcp_below_rcp else "")})
    t3 = tables["table3"]
    for _, r in t3.iterrows():
        for p in ("ls", "fb"):
            for side, q in (("low", "phi_min_fast"), ("high", "phi_max_fast")):
                rows.append({"table": "Table 3", **_where(r), "row": p.upper(), "quantity": q,
                             "ours": r[f"{p}_phi_{side}"], "half_width": r[f"{p}_phi_{side}_half_width"],
                             "paper": r[f"{p}_phi_{side}_paper"], "paper_derived": False,
                             "ours_minus_paper": r[f"{p}_phi_{side}_minus_paper"],
                             "minus_paper_in_half_widths": r[f"{p}_phi_{side}_minus_paper_in_half_widths"],
                             "note": r[f"{p}_status"] or (PAPER_MIN_NOTE if side == "low" else "")})
    for _, r in tables["table4"].iterrows():
        for col in ("phi_LT", "phi_RCP", "phi_GCP"):
            rows.append({"table": "Table 4", **_where(r), "row": "", "quantity": col,
                         "ours": r[col], "half_width": r[f"{col}_half_width"], "paper": r[f"{col}_paper"],
                         "paper_derived": r[f"{col}_paper_derived"], "ours_minus_paper": r[f"{col}_minus_paper"],
                         "minus_paper_in_half_widths": r[f"{col}_minus_paper_in_half_widths"],
                         "note": TAKEN_FROM_PAPER if col == "phi_GCP" and _taken_from_paper(r) else
                         GCP_BELOW_RCP if col == "phi_GCP" and r.gcp_below_rcp else ""})
    return pd.DataFrame(rows)


MODELS_CAPTION = "Table 4 (continued): our phi_RCP beside the published models"


def models_formatted(t4: pd.DataFrame) -> pd.DataFrame:
    """Per distribution: our phi_RCP, each model's and ours − model."""
    idx = "distribution" if "distribution" in t4.columns else "σ"
    rows = []
    for _, r in t4.iterrows():
        row = {idx: _label(r), **_n_cells(r), "φ_RCP (ours)": _pm(r.phi_RCP, r.phi_RCP_half_width)}
        for m, label in MODELS.items():
            row[label] = _fmt(r[f"model_{m}"])
            row[f"ours − {label}"] = _signed(r[f"phi_RCP_minus_{m}"])
        rows.append(row)
    return pd.DataFrame(rows).set_index(idx)


def _model_notes(t4: pd.DataFrame) -> list[str]:
    from ..analysis.psd_models import CITATIONS, VALIDITY

    notes = [f"{label}: {CITATIONS[m]}; {VALIDITY[m]}." for m, label in MODELS.items()]
    notes.append(f"Santos et al.'s input φ_mono = {float(t4.santos_phi_mono.iloc[0]):.4f}: "
                 f"{t4.attrs.get('santos_input', '')}.")
    return notes


def _tex(text) -> str:
    for plain, tex in (("_", r"\_"), ("σ", r"$\sigma$"), ("φ", r"$\varphi$"), ("±", r"$\pm$"), ("−", "$-$"),
                       ("α", r"$\alpha$"), ("†", r"$^\dagger$"), ("%", r"\%"), ("^fast", r"$^{\rm fast}$")):
        text = str(text).replace(plain, tex)
    return text


def _latex(df: pd.DataFrame, caption: str, notes: list[str]) -> str:
    cols = list(df.columns)
    lines = [r"\begin{table}", r"\centering", f"\\caption{{{_tex(caption)}}}",
             r"\begin{tabular}{l" + "c" * len(cols) + "}",
             r"\hline", " & ".join([_tex(df.index.name or "")] + [_tex(c) for c in cols]) + r" \\", r"\hline"]
    for idx, row in df.iterrows():
        lines.append(" & ".join([_tex(idx)] + [_tex(v) for v in row.values]) + r" \\")
    lines += [r"\hline", r"\end{tabular}"]
    lines += [f"\\par\\footnotesize {_tex(n)}" for n in notes]
    lines += [r"\end{table}"]
    return "\n".join(lines) + "\n"


def _markdown(df: pd.DataFrame, caption: str, notes: list[str]) -> str:
    cols = [df.index.name or ""] + [str(c) for c in df.columns]
    lines = [f"**{caption}**", "", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for idx, row in df.iterrows():
        lines.append("| " + " | ".join([str(idx)] + [str(v) for v in row.values]) + " |")
    lines += [""] + [f"{n}  " for n in notes]
    return "\n".join(lines) + "\n"


CAPTIONS = {
    "table2": "Table 2: GCP limits phi_GCP = c0 of cubic fits in sqrt(gamma) with 95% confidence half-widths",
    "table3": "Table 3: min and max closest jamming densities of fast compressions",
    "table4": "Table 4: lowest typical (LT), RCP and GCP densities",
}


def _notes(name: str, t: pd.DataFrame) -> list[str]:
    notes = [f"Paper: {paper_reference.CITATION} (N = 10^4). A half-width is that of our 95 % confidence interval; "
             "– = not available."]
    if "n" in t.columns:
        sizes = ", ".join(f"{p.upper()} {k}" for p, k in paper_reference.FAST_SAMPLE_SIZES.items())
        notes.append("Rows per N; the extrapolated rows come from the finite-size scaling of docs/finite_size.md "
                     "(band edges: mean and width of the fast φ_J distribution as N^-1/2, the sample min/max "
                     f"expected for the paper's sample sizes, {sizes} packings; φ_GCP as N^-1/2). Their half-width "
                     "is half the 95 % bootstrap (edges) or fit (φ_GCP) interval.")
    if name == "table3":
        notes.append(f"† {PAPER_MIN_NOTE}; the paper gives the LS and FB minima as differing by <= 1e-3. "
                     "The sample min/max has no confidence interval (docs/statistics.md).")
    if name == "table4":
        notes.append("* paper cell lost in the text and recomputed by the paper's rule (mean of the four Table 2 "
                     "entries).")
        flagged = [_label(r) + (f" (N = {n_label(r.n, r.extrapolated)})" if "n" in r.index else "")
                   for _, r in t.iterrows() if r.gcp_below_rcp]
        if flagged:
            where = "" if "distribution" in t.columns else "σ = "
            notes.append(f"Flag: φ_GCP < φ_RCP at {where}{', '.join(flagged)} (too little data, not a result).")
    return notes


def _tables_at_one_n(ds) -> dict[str, pd.DataFrame]:
    t2, t3 = table2(ds), table3(ds)
    t4 = table4(ds, t2, t3)
    return {"table2": _flag_table2(t2, t4), "table3": t3, "table4": t4}


#: The N a ladder's tables are extrapolated to: the paper's, and the limit.
EXTRAPOLATION_TARGETS = (float(paper_reference.PAPER_N), math.inf)


def _with_n(t: pd.DataFrame, n: float, extrapolated: bool) -> pd.DataFrame:
    t = t.copy()
    t.insert(0, "n", float(n))
    t.insert(1, "extrapolated", extrapolated)
    return t


def compute_tables(ds) -> dict[str, pd.DataFrame]:
    """Tables 2-4 of a dataset; for packings at several N, per N and extrapolated (column ``n``); with containers,
    per container (columns ``container`` and ``container_spec``)."""
    keys = container_keys(ds)
    if not keys:
        return _tables_in_one_container(ds)
    parts = []
    for key in keys:
        sub = ds.isel(packing=np.flatnonzero(ds["container"].values == key))
        spec = str(sub["container_spec"].values[0])
        tables = _tables_in_one_container(sub)
        for name, t in tables.items():
            t = t.copy()
            if spec != "periodic":  # the paper's values, and the conventional phi_GCP of equal spheres, are the bulk's
                for col in t.columns:
                    if "paper" in col and t[col].dtype.kind == "f":
                        t[col] = np.nan
                    elif col.endswith("_paper_derived"):
                        t[col] = False
                if "phi_GCP_source" in t.columns:
                    conventional = t["phi_GCP_source"] == "paper"
                    t.loc[conventional, ["phi_GCP", "phi_GCP_half_width"]] = np.nan
                    t.loc[conventional, "phi_GCP_source"] = "none: the conventional 0.65 is the bulk's"
                    if "gcp_below_rcp" in t.columns:
                        t.loc[conventional, "gcp_below_rcp"] = False
            t.insert(0, "container", key)
            t.insert(1, "container_spec", spec)
            tables[name] = t
        parts.append(tables)
    out = {name: pd.concat([p[name] for p in parts], ignore_index=True) for name in parts[0]}
    for name in out:
        out[name].attrs.update(parts[0][name].attrs)
    return out


def _tables_in_one_container(ds) -> dict[str, pd.DataFrame]:
    """Tables 2-4 of packings in one container (or of a dataset without containers)."""
    sizes = sizes_in(ds)
    if len(sizes) <= 1:
        return _tables_at_one_n(ds)
    parts = [{k: _with_n(t, n, False) for k, t in _tables_at_one_n(at_n(ds, n)).items()} for n in sizes]
    t2 = pd.concat([p["table2"] for p in parts], ignore_index=True)
    t3x = table3_extrapolated(ds)
    t2x = table2_extrapolated(t2)
    for target in EXTRAPOLATION_TARGETS:
        t3_at = t3x[t3x.n == target].drop(columns=["n", "extrapolated"]).reset_index(drop=True)
        t2_at = t2x[t2x.n == target].drop(columns=["n", "extrapolated"]).reset_index(drop=True)
        t4_at = table4(ds, t2_at, t3_at)
        parts.append({"table2": _with_n(_flag_table2(t2_at, t4_at), target, True),
                      "table3": _with_n(t3_at, target, True), "table4": _with_n(t4_at, target, True)})
    out = {name: pd.concat([p[name] for p in parts], ignore_index=True) for name in ("table2", "table3", "table4")}
    out["table3"].attrs["method"] = band_settings(ds)["method"]
    out["table4"].attrs.update(parts[-1]["table4"].attrs)
    return out


def _fast_samples(df: pd.DataFrame, group: dict, protocol: str, limit: float) -> dict[int, np.ndarray]:
    """N -> fast phi_J of one distribution and protocol (the Table 3 band at each N)."""
    fast = df[(df.protocol == protocol) & (df.distribution == group["distribution"]) & (df.inverse_rate < limit)]
    return {int(n): sub.phi_J.dropna().values for n, sub in fast.groupby("n")}


def fast_bands(ds) -> list[tuple[dict, dict[str, dict[int, np.ndarray]]]]:
    """Per distribution (the tables' rows, in order): its group and, per protocol, N -> the fast phi_J at that N
    (the Table 3 band at each N), for the N with at least ``bands.min_packings`` (and 2) fast packings."""
    cfg = {**FAST_DEFAULTS, **dataset_config(ds).get("fast", {})}
    minimum = _min_scaling_packings(ds)
    df = _frame(ds)
    df["n"] = ds["n"].values
    out = []
    for g in _groups(df):
        by_protocol = {p: _fast_samples(df, g, p, cfg[f"{p}_max_inverse_rate"]) for p in ("ls", "fb")}
        out.append((g, {p: {n: x for n, x in samples.items() if len(x) >= minimum}
                        for p, samples in by_protocol.items()}))
    return out


def _min_scaling_packings(ds) -> int:
    """Fast packings an N needs to enter the finite-size scaling: ``bands.min_packings``, and 2 for a width."""
    return max(int(band_settings(ds)["min_packings"]), 2)


def _named(bands) -> bool:
    return any(not math.isfinite(g["sigma"]) for g, _ in bands)


def table3_extrapolated(ds) -> pd.DataFrame:
    """Table 3's columns at N = 10^4 and N -> infinity, from the finite-size scaling of each band: the sample
    min/max expected for the paper's sample sizes (85 LS, 165 FB packings) and the alpha-quantiles, each with its
    bootstrap confidence interval; the edge ``bands.method`` reports has half of that interval as its half-width.
    A band with packings at fewer than 2 N (at least ``bands.min_packings`` each) is not estimable."""
    bands = band_settings(ds)
    method, alpha, conf = bands["method"], float(bands["alpha"]), float(bands["confidence"])
    minimum = _min_scaling_packings(ds)
    paper, paper_min = paper_reference.table3(), paper_reference.table3_min_unattributed()
    groups = fast_bands(ds)
    named = _named(groups)
    rows = {t: [] for t in EXTRAPOLATION_TARGETS}
    for group, by_protocol in groups:
        cells = {t: _start(group, named) for t in EXTRAPOLATION_TARGETS}
        for protocol in ("ls", "fb"):
            usable = by_protocol[protocol]
            size = paper_reference.FAST_SAMPLE_SIZES[protocol]
            p = f"{protocol}_"
            status = "" if len(usable) >= 2 else not_estimable(
                len(usable), f"N values with >= {minimum} fast packings; finite-size scaling needs 2")
            for side in finite_size.SIDES:
                pred = {m: finite_size.predict_edges(usable, EXTRAPOLATION_TARGETS, side, m,
                                                     sample_size=size if m == "minmax" else None, alpha=alpha,
                                                     confidence=conf) if not status else None
                        for m in finite_size.METHODS}
                ref = (paper_row(paper_min, group["paper_sigma"]) if side == "low"
                       else paper_row(paper, group["paper_sigma"], protocol=protocol.upper()))
                paper_value = math.nan if ref is None else float(ref.phi_min if side == "low" else ref.phi_max)
                for i, t in enumerate(EXTRAPOLATION_TARGETS):
                    row = cells[t]
                    row[p + "n_fast"], row[p + "status"] = size, status
                    mm, q = (pred["minmax"][i], pred["quantile"][i]) if not status else (None, None)
                    row[p + ("phi_min_fast" if side == "low" else "phi_max_fast")] = mm.value if mm else math.nan
                    row[f"{p}phi_{side}_quantile"] = q.value if q else math.nan
                    row[f"{p}phi_{side}_ci_low"], row[f"{p}phi_{side}_ci_high"] = (
                        q.interval if q else (math.nan, math.nan))
                    chosen = pred[method][i] if not status else None
                    value = chosen.value if chosen else math.nan
                    half = (chosen.interval[1] - chosen.interval[0]) / 2 if chosen else math.nan
                    row[f"{p}phi_{side}"], row[f"{p}phi_{side}_half_width"] = value, half
                    row[f"{p}phi_{side}_paper"] = paper_value
                    row[f"{p}phi_{side}_minus_paper"], row[f"{p}phi_{side}_minus_paper_in_half_widths"] = _compare(
                        value, half, paper_value)
        for t in EXTRAPOLATION_TARGETS:
            rows[t].append(cells[t])
    out = pd.concat([_with_n(pd.DataFrame(rows[t]), t, True) for t in EXTRAPOLATION_TARGETS], ignore_index=True)
    out.attrs["method"] = method
    return out


def finite_size_table(ds) -> pd.DataFrame:
    """Per distribution, protocol and band edge of a ladder of N: the scaling fitted to every N (mu_inf, a, b of
    docs/finite_size.md) and its honest check, the edge at the largest N predicted from the smaller N alone against
    the one measured there, with the prediction interval (needs 3 N; else "not estimable")."""
    bands = band_settings(ds)
    method, alpha, conf = bands["method"], float(bands["alpha"]), float(bands["confidence"])
    groups = fast_bands(ds)
    named = _named(groups)
    rows = []
    for group, by_protocol in groups:
        for protocol in ("ls", "fb"):
            usable = by_protocol[protocol]
            base = {**_start(group, named), "protocol": protocol,
                    "n_values": " ".join(str(n) for n in sorted(usable)),
                    "packings": " ".join(str(len(usable[n])) for n in sorted(usable))}
            fit = finite_size.fit_scaling(usable) if len(usable) >= 2 else None
            for side in finite_size.SIDES:
                row = {**base, "edge": side, "mu_inf": fit.mu_inf if fit else math.nan,
                       "a": fit.a if fit else math.nan, "b": fit.b if fit else math.nan, "method": method}
                if len(usable) >= 3:
                    v = finite_size.leave_largest_out(usable, side, method, alpha, confidence=conf)
                    row.update(held_out_n=v.n_particles, measured=v.measured, predicted=v.predicted.value,
                               error=v.error, prediction_low=v.predicted.prediction_interval[0],
                               prediction_high=v.predicted.prediction_interval[1],
                               within=v.within_prediction_interval, status="")
                else:
                    row.update(held_out_n=math.nan, measured=math.nan, predicted=math.nan, error=math.nan,
                               prediction_low=math.nan, prediction_high=math.nan, within=False,
                               status=not_estimable(len(usable), "N values; leaving one out needs 3"))
                rows.append(row)
    return pd.DataFrame(rows)


FINITE_SIZE_CAPTION = ("Finite-size scaling of the fast bands: the fit to every N, and the edge at the largest N "
                       "predicted from the smaller N alone")


def finite_size_formatted(t: pd.DataFrame) -> pd.DataFrame:
    idx = "distribution" if "distribution" in t.columns else "σ"
    rows = []
    for _, r in t.iterrows():
        lo, hi = r.prediction_low, r.prediction_high
        rows.append({
            idx: _label(r), "protocol": r.protocol.upper(), "edge": "φ_min^fast" if r.edge == "low" else "φ_max^fast",
            "N (packings)": ", ".join(f"{n} ({k})" for n, k in zip(r.n_values.split(), r.packings.split())),
            "μ_∞": _fmt(r.mu_inf), "a": _fmt(r.a, 3), "b": _fmt(r.b, 3),
            "held-out N": r.status if r.status else f"{int(r.held_out_n)}",
            "measured": _fmt(r.measured), "predicted": _fmt(r.predicted),
            "predicted − measured": _signed(r.error),
            "95 % prediction interval": "–" if r.status else f"[{_fmt(lo)}, {_fmt(hi)}]",
            "inside?": "" if r.status else ("yes" if r.within else "**no**"),
        })
    return pd.DataFrame(rows).set_index(idx) if rows else pd.DataFrame()


FINITE_SIZE_NOTES = [
    "Model (docs/finite_size.md): mean μ(N) = μ_∞ − a N^-1/2, standard deviation s(N) = b N^-1/2, normal shape; "
    "fitted before any comparison with the paper. The held-out check refits without the largest N and predicts "
    "the edge that a sample of the measured size shows there.",
]


def table2_extrapolated(t2: pd.DataFrame) -> pd.DataFrame:
    """Table 2 at N = 10^4 and N -> infinity: each curve's estimable phi_GCP at the ladder's N, extrapolated as
    phi_GCP(N) = phi_GCP(inf) - c N^-1/2 (:func:`spherejam.workflow.finite_size.extrapolate`)."""
    if t2.empty:
        return pd.DataFrame(columns=["n", "extrapolated"] + list(TABLE2_COLUMNS))
    key = "distribution" if "distribution" in t2.columns else "sigma"
    rows = []
    for _, sub in t2.groupby(["curve", key], sort=False):
        ok = sub[sub.status == ""]
        predictions = finite_size.extrapolate(ok.n, ok.phi_gcp, ok.half_width, EXTRAPOLATION_TARGETS)
        first = sub.iloc[0]
        for pred in predictions:
            row = {c: first[c] for c in ("curve", "protocol", "variable", "distribution", "psd", "sigma")
                   if c in sub.columns}
            row.update(n=pred.n_particles, extrapolated=True, phi_gcp=pred.value, half_width=pred.half_width,
                       n_points=int(ok.n_points.sum()),
                       status="" if math.isfinite(pred.value) else not_estimable(
                           len(ok), "N values with an estimable fit; extrapolation needs 2"))
            row["paper_phi_gcp"] = float(first.paper_phi_gcp)  # the paper's value is the same at every N
            row["paper_half_width"] = float(first.paper_half_width)
            row["minus_paper"], row["minus_paper_in_half_widths"] = _compare(
                row["phi_gcp"], row["half_width"], row["paper_phi_gcp"])
            rows.append(row)
    out = pd.DataFrame(rows)
    out["estimable"] = out.status == ""
    return out


#: The files :func:`write_tables` writes into its folder (and, for a ladder of N, ``finite_size.{csv,md}``).
TABLE_FILES = tuple(f"{name}.{ext}" for name in ("table2", "table3", "table4") for ext in ("csv", "md", "tex")) + (
    "comparison.csv", "comparison.md")


def write_tables(ds, outdir: str | os.PathLike) -> list[Path]:
    """Write every table as ``<name>.csv`` (machine-readable, long), ``.md`` and ``.tex`` (with the paper's values),
    and ``comparison.csv`` / ``comparison.md``: every cell set against the paper, in one table."""
    outdir = Path(outdir)
    texts = {}
    tables = compute_tables(ds)
    method = band_settings(ds)["method"]
    for name, t in tables.items():
        wide = formatted(name, t, method)
        notes = _notes(name, t)
        md, tex = _markdown(wide, CAPTIONS[name], notes), _latex(wide, CAPTIONS[name], notes)
        if name == "table4" and len(t):  # the models beside our phi_RCP
            models, model_notes = models_formatted(t), _model_notes(t)
            md += "\n" + _markdown(models, MODELS_CAPTION, model_notes)
            tex += "\n" + _latex(models, MODELS_CAPTION, model_notes)
        texts[f"{name}.csv"] = t.to_csv(index=False, float_format="%.10g")
        texts[f"{name}.md"] = md
        texts[f"{name}.tex"] = tex
    if len(sizes_in(ds)) > 1:
        scaling = finite_size_table(reference_packings(ds))
        texts["finite_size.csv"] = scaling.to_csv(index=False, float_format="%.10g")
        texts["finite_size.md"] = _markdown(finite_size_formatted(scaling), FINITE_SIZE_CAPTION, FINITE_SIZE_NOTES)
    comp = comparison(tables)
    texts["comparison.csv"] = comp.to_csv(index=False, float_format="%.10g")
    texts["comparison.md"] = comparison_markdown(tables, comp)
    with atomic_folder(outdir, texts) as tmp:  # one set of tables: all new or all old
        for file_name, text in texts.items():
            (tmp / file_name).write_text(text)
    return [outdir / file_name for file_name in texts]


def comparison_markdown(tables: dict[str, pd.DataFrame], comp: pd.DataFrame | None = None) -> str:
    """The "Comparison with the paper" text: the flags first, then the three tables."""
    comp = comparison(tables) if comp is None else comp
    lines = ["# Comparison with the paper", "", paper_reference.CITATION, ""]
    flagged = comp[comp.note == GCP_BELOW_RCP]
    if len(flagged):
        lines.append("**Flagged (φ_GCP < φ_RCP, a sign of too little data):** " + "; ".join(
            f"{r.table} {_label(r) if 'distribution' in r.index else f'σ = {r.sigma:g}'} {r.row} {r.quantity}"
            .replace("  ", " ") for _, r in flagged.iterrows()))
    else:
        lines.append("No row has φ_GCP < φ_RCP.")
    n_est = int(comp.ours.notna().sum())
    lines += ["", f"{n_est} of {len(comp)} cells estimable.", ""]
    for name, t in tables.items():
        lines.append(_markdown(formatted(name, t), CAPTIONS[name], _notes(name, t)))
    return "\n".join(lines) + "\n"


__all__ = ["table2", "table3", "table4", "compute_tables", "comparison", "write_tables", "N_COEFFICIENTS"]
