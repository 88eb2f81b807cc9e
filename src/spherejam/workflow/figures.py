"""The paper's Figures 2-7, plus structure and contact-force figures, drawn from the results dataset alone.

Each ``fig*`` function takes the dataset and returns a matplotlib Figure; :func:`save_figure` writes PNG and PDF.
Fig. 1 (a rendered packing) needs OVITO and lives in :mod:`spherejam.workflow.render`. Colours mark sigma and so do the
symbols (:data:`SIGMA_MARKERS`), as in the paper.
"""

from __future__ import annotations

import math
import os
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_output
from ..core.errors import InputError
from .bands import FAST_DEFAULTS
from . import finite_size, paper_reference
from . import container_figures
from .dataset import at_n, container_keys, dataset_config, reference_packings, sizes_in
from .plotting import pyplot
from .tables import TABLE2_ROWS, band_settings, completed_phi_J, compute_tables, fast_bands, paper_row

#: One symbol per sigma, in increasing sigma (the paper's number distributions tell sigma apart by symbol too).
SIGMA_MARKERS = "osD^v<>ph*"
#: Densest packing of equal spheres (FCC/HCP), pi / (3 sqrt 2), and the tunnelled crystals' 2/3 of it (Fig. 6).
PHI_HCP = math.pi / (3 * math.sqrt(2))
PHI_TUNNELLED = 2 * PHI_HCP / 3
#: Panels (a)-(d) of Figs. 2 and 7: LS phi, LS phi_J, FB phi, FB phi_J (Table 2 rows in the paper's panel order).
PANEL_ROWS = tuple(TABLE2_ROWS[i] for i in (0, 2, 1, 3))


def _sigmas(ds):
    """The sigmas of the ``sigmas`` runs (named distributions have sigma NaN: they are in Fig. 5 and the tables)."""
    return sorted({s for s in ds.sigma.values.tolist() if math.isfinite(s)})


def _colours(sigmas):
    plt = pyplot()
    cmap = plt.get_cmap("viridis")
    smax = max(max(sigmas), 1e-9)
    return {s: cmap(0.9 * s / smax) for s in sigmas}


def _markers(sigmas):
    return {s: SIGMA_MARKERS[k % len(SIGMA_MARKERS)] for k, s in enumerate(sorted(sigmas))}


def _no_data(ax, what="no data"):
    ax.text(0.5, 0.5, what, ha="center", va="center", transform=ax.transAxes, color="0.5")


def _sel(ds, protocol=None, sigma=None):
    mask = np.ones(ds.sizes["packing"], dtype=bool)
    if protocol is not None:
        mask &= ds.protocol.values == protocol
    if sigma is not None:
        mask &= np.isclose(ds.sigma.values, sigma)
    return mask


def _values(ds, var):
    return completed_phi_J(ds) if var == "phi_J" else ds[var].values.astype(float)


def _fast_limits(ds):
    return {**FAST_DEFAULTS, **dataset_config(ds).get("fast", {})}


def _gcp_monodisperse(ds):
    return float(dataset_config(ds).get("gcp_monodisperse", 0.65))


def _edge_mark(ax, y, colour, left: bool):
    """A short horizontal line at the left or right edge of the panel (the paper's phi_RCP and phi_GCP marks)."""
    ax.axhline(y, xmin=0 if left else 0.94, xmax=0.06 if left else 1, color=colour, lw=2.5, solid_capstyle="butt")


def _gcp_of_row(t2, label, sigma, gcp0):
    """phi_GCP of one Table 2 row (curve ``label``) at ``sigma``; sigma = 0 takes the config's monodisperse value."""
    if sigma == 0:
        return gcp0
    row = t2.loc[(t2.curve == label) & np.isclose(t2.sigma, sigma), "phi_gcp"] if len(t2) else []
    return float(row.iloc[0]) if len(row) else math.nan


def fig2(ds):
    """phi and phi_J vs 1/gamma for LS and FB, points of each sigma joined by lines.

    phi_RCP (Table 4) is marked at the left of the densified panels (b, d), and each panel's own Table 2 phi_GCP at
    its right.
    """
    plt = pyplot()
    tables = compute_tables(ds)
    t2, t4 = tables["table2"], tables["table4"]
    sigmas = _sigmas(ds)
    col, mk = _colours(sigmas), _markers(sigmas)
    gcp0 = _gcp_monodisperse(ds)
    fig, axes = plt.subplots(2, 2, figsize=(10, 8), sharey="col")
    for ax, (label, protocol, var, _), letter in zip(axes.flat, PANEL_ROWS, "abcd"):
        for s in sigmas:
            m = _sel(ds, protocol, s)
            if m.any() and var in ds:
                order = np.argsort(ds.inverse_rate.values[m])
                ax.plot(ds.inverse_rate.values[m][order], _values(ds, var)[m][order], "-", marker=mk[s], ms=4,
                        lw=1, color=col[s], label=f"σ = {s:g}")
            if var == "phi_J":
                rcp = t4.loc[np.isclose(t4.sigma, s), "phi_RCP"]
                if len(rcp) and np.isfinite(rcp.iloc[0]):
                    _edge_mark(ax, rcp.iloc[0], col[s], left=True)
            gcp = _gcp_of_row(t2, label, s, gcp0)
            if np.isfinite(gcp):
                _edge_mark(ax, gcp, col[s], left=False)
        ax.set_xscale("log")
        ax.set_title(f"({letter}) {label}", loc="left", fontsize=10)
        ax.set_xlabel("inverse compression rate 1/γ")
        ax.grid(alpha=0.3)
    return _finish_protocol_grid(fig, axes)


def fig3(ds):
    """phi_J of the validation grid vs the true 1/gamma of its LS packings, coloured by (a) the decrease factor and
    (b) the initial rate; one symbol per sigma."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    if "grid_run" not in ds.dims:
        for ax in axes:
            _no_data(ax, "validation grid disabled in this experiment")
        return fig
    from matplotlib.lines import Line2D

    grid_sigmas = sorted(set(ds.grid_sigma.values.tolist()))
    mk = _markers(grid_sigmas)
    grid_phi_j = ds.grid_phi_J.values.astype(float).copy()
    if "grid_completed" in ds:
        grid_phi_j[ds.grid_completed.values != 1] = np.nan  # cut MLS run: not a closest-jamming density
    x = ds.grid_inverse_rate.values
    ls_x = ds.inverse_rate.values[ds.protocol.values == "ls"] if "packing" in ds.dims else x
    lo, hi = np.nanmin(np.concatenate([x, ls_x])), np.nanmax(np.concatenate([x, ls_x]))
    n_rates = len(set(np.round(x, 12).tolist()))
    for ax, key, title in ((axes[0], "decrease_factor", "(a) compression rate decrease factor"),
                           (axes[1], "initial_rate", "(b) initial compression rate")):
        values = sorted(set(ds[key].values.tolist()))
        cmap = plt.get_cmap("plasma")
        colour = {v: cmap(0.85 * k / max(len(values) - 1, 1)) for k, v in enumerate(values)}
        for v in values:
            for s in grid_sigmas:
                m = (ds[key].values == v) & np.isclose(ds.grid_sigma.values, s)
                ax.plot(x[m], grid_phi_j[m], mk[s], ms=6, mfc="none", mew=1.3, color=colour[v], ls="none")
        handles = [Line2D([], [], marker="s", ls="none", color=colour[v], label=f"{v:g}") for v in values]
        handles += [Line2D([], [], marker=mk[s], ls="none", mfc="none", color="0.3", label=f"σ = {s:g}")
                    for s in grid_sigmas]
        ax.legend(handles=handles, fontsize=7, ncol=2, title=key.replace("_", " "), title_fontsize=7)
        ax.set_xscale("log")
        ax.set_xlim(lo / 2, hi * 2)  # the experiment's LS range, so one can see where the grid's packings sit
        ax.set_xlabel("inverse compression rate 1/γ of the LS packing")
        ax.set_title(title, loc="left", fontsize=10)
        ax.grid(alpha=0.3)
    if n_rates < 2:
        axes[1].text(0.02, 0.03, f"this grid has LS packings of one rate only (1/γ = {x[0]:g}),\n"
                     "so it cannot show the fast/slow contrast of the paper", transform=axes[1].transAxes,
                     fontsize=7, color="0.35", va="bottom")
    axes[0].set_ylabel("closest jamming density φ$_J$")
    fig.tight_layout()
    return fig


def _bin_edges(v):
    """Histogram bins of one sigma's own band: numpy's 'auto' rule, at most 30 bins; one value gets one narrow bin."""
    if v.max() - v.min() < 1e-9:
        return np.array([v.min() - 5e-5, v.max() + 5e-5])
    edges = np.histogram_bin_edges(v, bins="auto")
    n = int(np.clip(len(edges) - 1, 1, 30))
    return np.linspace(v.min(), v.max(), n + 1)


def fig4(ds):
    """Number distributions of phi_J for fast compressions, (a) LS and (b) FB; each sigma on its own bins, drawn as
    symbols joined by lines."""
    plt = pyplot()
    fast = _fast_limits(ds)
    sigmas = _sigmas(ds)
    col, mk = _colours(sigmas), _markers(sigmas)
    phi_j = completed_phi_J(ds)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, protocol, title in ((axes[0], "ls", "(a) LS, 1/γ < {:g}"), (axes[1], "fb", "(b) FB, 1/γ < {:g}")):
        limit = fast[f"{protocol}_max_inverse_rate"]
        drawn = 0
        for s in sigmas:
            v = phi_j[_sel(ds, protocol, s) & (ds.inverse_rate.values < limit)]
            v = v[np.isfinite(v)]
            if len(v) == 0:
                continue
            counts, edges = np.histogram(v, bins=_bin_edges(v))
            centres = 0.5 * (edges[:-1] + edges[1:])
            ax.plot(centres, counts, "-", marker=mk[s], ms=5, lw=1, color=col[s], label=f"σ = {s:g} (n = {len(v)})")
            drawn += 1
        if drawn:
            ax.legend(fontsize=8)
        else:
            _no_data(ax, "no fast compressions")
        ax.set_title(title.format(limit), loc="left", fontsize=10)
        ax.set_xlabel("closest jamming density φ$_J$")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("number of packings")
    axes[0].set_ylim(bottom=0)
    axes[0].yaxis.get_major_locator().set_params(integer=True)
    fig.tight_layout()
    return fig


@lru_cache(maxsize=64)
def _farr_groot(sigma: float) -> float:
    from ..analysis.farr_groot import phi_rcp_lognormal

    return phi_rcp_lognormal(sigma)


def farr_groot_sigmas(ds) -> np.ndarray:
    """Where Fig. 5 shows the Farr-Groot phi_RCP: the paper's sigmas (0 ... 0.3) and this run's."""
    from .paper_reference import TABLE34_SIGMAS

    return np.array(sorted({round(float(s), 12) for s in (*TABLE34_SIGMAS, *_sigmas(ds))}))


#: Fig. 5's marker of each size-distribution family (colour tells the quantity).
FAMILY_MARKERS = {"lognormal": "o", "gaussian": "s", "uniform": "D", "bidisperse": "^", "powerlaw": "v",
                  "table": "*", "list": "P"}


def _table4_distributions(t4):
    """(delta, family) of each Table 4 row: sigma itself for a sigmas-only table (the paper's log-normals)."""
    from ..core.size_distribution import parse

    if "psd" not in t4.columns:
        return np.asarray(t4.sigma, dtype=float), ["lognormal"] * len(t4)
    dists = [parse(spec) for spec in t4.psd]
    delta = [float(r.sigma) if math.isfinite(r.sigma) else d.descriptors().delta
             for d, (_, r) in zip(dists, t4.iterrows())]
    return np.array(delta), [d.family for d in dists]


def fig5(ds):
    """phi_LT, phi_RCP and phi_GCP vs the relative std delta of the diameters (Table 4; sigma for the paper's
    log-normals), one marker per distribution family, with the published models of phi_RCP (log-normal curves;
    one mark per other distribution) and the paper's Table 4."""
    from ..analysis.psd_models import PHI_RCP_MONO_PAPER, desmond_weeks, santos
    from .paper_reference import table4 as paper_table4

    plt = pyplot()
    t4 = compute_tables(ds)["table4"]
    paper = paper_table4()
    fig, ax = plt.subplots(figsize=(6.5, 6.4))
    fg_sigmas = farr_groot_sigmas(ds)
    ax.plot(fg_sigmas, [_farr_groot(float(s)) for s in fg_sigmas], "s", color="tab:blue", mfc="none", ms=7,
            label="φ$_{RCP}$ models (log-normal): Farr–Groot, our reconstruction", gid="farr_groot")
    grid = np.linspace(0, max(0.3, float(np.nanmax(fg_sigmas))), 61)
    phi_mono = float(t4.santos_phi_mono.iloc[0]) if len(t4) and "santos_phi_mono" in t4 else PHI_RCP_MONO_PAPER
    ax.plot(grid, [desmond_weeks(x, 3 * x + x**3) for x in grid], "--", color="tab:green", lw=1,
            label="Desmond–Weeks 2014", gid="desmond_weeks")
    ax.plot(grid, [santos(1 / (1 + x * x), phi_mono) for x in grid], ":", color="tab:olive", lw=1.3,
            label=f"Santos et al. 2014 (φ$_{{mono}}$ = {phi_mono:.4f})", gid="santos")
    delta, families = _table4_distributions(t4)
    other = [i for i, f in enumerate(families) if f != "lognormal"]
    for m, colour, name in (("farr_groot", "tab:blue", "Farr–Groot"), ("desmond_weeks", "tab:green", "Desmond–Weeks"),
                            ("santos", "tab:olive", "Santos et al.")):
        if other and f"model_{m}" in t4:
            ax.plot(delta[other], t4[f"model_{m}"].values[other], "_", color=colour, ms=12, mew=2, ls="none",
                    gid=f"model_{m}_marks", label=f"{name} at each other distribution")
    styles = (("phi_LT", "tab:red", "φ$_{LT}$"), ("phi_RCP", "m", "φ$_{RCP}$"), ("phi_GCP", "c", "φ$_{GCP}$"))
    for col, colour, name in styles:
        for family in dict.fromkeys(families):
            rows = [i for i, f in enumerate(families) if f == family]
            ax.plot(delta[rows], t4[col].values[rows], FAMILY_MARKERS.get(family, "o"), color=colour, ms=8, mew=1.6,
                    mfc="none", ls="none", label=f"{name}, this run ({family})",
                    gid=f"run_{col}" if family == "lognormal" else f"run_{col}_{family}")
    for col, colour, name in styles:
        marker = "x"
        printed = paper[col].notna() & ~paper[f"{col}_derived"]
        derived = paper[col].notna() & paper[f"{col}_derived"]
        ax.plot(paper.index[printed], paper[col][printed], marker, color=colour, ms=5, alpha=0.45, mew=1,
                mfc="none", ls="none", label=f"{name}, paper (N = 10⁴)", gid=f"paper_{col}")
        if derived.any():
            ax.plot(paper.index[derived], paper[col][derived], marker, color=colour, ms=5, alpha=0.45, mew=1,
                    mfc="none", ls="none", label=f"{name}, paper: mean of its Table 2", gid=f"paper_{col}_derived",
                    markeredgecolor="0.5")
    ax.set_xlabel("relative standard deviation δ of the diameters (σ of the paper's log-normals)")
    ax.set_ylabel("packing density")
    ax.legend(fontsize=7, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.13))  # below: no data hidden
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def _envelope(x, y):
    """Per distinct x: min and max of y (NaN left out), sorted by x."""
    ok = np.isfinite(x) & np.isfinite(y)
    xs = np.unique(x[ok])
    return xs, np.array([y[ok][x[ok] == v].min() for v in xs]), np.array([y[ok][x[ok] == v].max() for v in xs])


def fig6(ds):
    """The jamming phase diagram (the paper's schematic Fig. 6) drawn from this run's packings.

    For (a) sigma = 0 and (b) the largest sigma: phi_J against generation time, the LS 1/gamma, with FB's 1/gamma
    divided by the ratio of the two fast-compression limits so that both protocols' fast regions coincide (left of
    the grey line). Red lines bound the typical closest jamming densities: [phi_LT, phi_RCP] (Table 4) for fast
    compressions, the spread of phi_J over both protocols for slower ones, and beyond the data (schematic) a
    convergence to phi_GCP (sigma > 0, dotted) or the crystallisation of equal spheres towards phi_HCP (dashed).
    Grey: untypical jammed configurations, bounded by phi_max (phi_HCP for sigma = 0, phi_GCP otherwise) and phi_L.
    """
    plt = pyplot()
    t4 = compute_tables(ds)["table4"]
    sigmas = _sigmas(ds)
    shown = sorted({sigmas[-1], *([0.0] if 0.0 in sigmas else [])})
    fast = _fast_limits(ds)
    limit = fast["ls_max_inverse_rate"]
    shift = fast["fb_max_inverse_rate"] / limit  # FB's 1/gamma on the LS scale
    phi_j = completed_phi_J(ds)
    time = np.where(ds.protocol.values == "fb", ds.inverse_rate.values / shift, ds.inverse_rate.values)
    fig, axes = plt.subplots(1, len(shown), figsize=(5.5 * len(shown), 4.6), squeeze=False)
    for ax, s, letter in zip(axes[0], shown, "ab"):
        m = _sel(ds, sigma=s) & np.isfinite(phi_j)
        row = t4[np.isclose(t4.sigma, s)]
        if not m.any() or not len(row) or not np.isfinite(row.phi_LT.iloc[0]):
            _no_data(ax, f"no fast compressions at σ = {s:g}")
            continue
        lt, rcp, gcp = (float(row[c].iloc[0]) for c in ("phi_LT", "phi_RCP", "phi_GCP"))
        xs, ymin, ymax = _envelope(time[m], phi_j[m])
        lo_x, hi_x = xs.min() / 2, xs.max() * 30
        # the band: flat at [phi_LT, phi_RCP] while compressions are fast, then the measured spread of phi_J
        slow = xs >= limit
        bx = np.concatenate([[lo_x, limit], xs[slow]])
        blo = np.concatenate([[lt, lt], ymin[slow]])
        bhi = np.concatenate([[rcp, rcp], np.maximum(ymax[slow], rcp)])
        monodisperse = s == 0
        top = max(bhi.max(), gcp) + 0.006
        bottom = min(lt, phi_j[m].min()) - 0.006
        phi_max = top if monodisperse else gcp  # phi_HCP lies far above the plot
        # schematic continuation to infinitely slow compression (log-linear in 1/gamma), the spread closing
        ex = np.geomspace(bx[-1], hi_x, 50)
        w = np.log(ex / ex[0]) / np.log(hi_x / ex[0])
        end, style, label = ((top, "--", "crystallisation (schematic)") if monodisperse
                             else (gcp, ":", "→ φ$_{GCP}$ (schematic)"))
        ehi = bhi[-1] + (end - bhi[-1]) * w
        elo = blo[-1] + (end - blo[-1]) * w if not monodisperse else ehi - (bhi[-1] - blo[-1]) * (1 - w)
        fx, flo, fhi = np.concatenate([bx, ex]), np.concatenate([blo, elo]), np.concatenate([bhi, ehi])
        ax.fill_between(fx, flo, fhi, color="tab:red", alpha=0.12, lw=0, label="typical")
        ax.fill_between(fx, fhi, np.maximum(fhi, phi_max), color="0.85", lw=0, label="untypical")
        ax.fill_between(fx, bottom, flo, color="0.85", lw=0)
        ax.plot(bx, blo, "-", color="tab:red", lw=2)
        ax.plot(bx, bhi, "-", color="tab:red", lw=2)
        ax.plot(ex, ehi, style, color="tab:red", lw=1.5, label=label)
        ax.plot(ex, elo, style, color="tab:red", lw=1.5)
        for protocol, marker, name in (("ls", ".", "LS"), ("fb", "x", f"FB (1/γ ÷ {shift:g})")):
            mm = m & (ds.protocol.values == protocol)
            ax.plot(time[mm], phi_j[mm], marker, color="0.3", ms=5, ls="none", label=f"φ$_J$, {name}")
        ax.axvline(limit, color="0.5", lw=1)
        for value, name in ((lt, "φ$_{LT}$"), (rcp, "φ$_{RCP}$"), (gcp, "φ$_{GCP}$")):
            ax.axhline(value, color="k", lw=0.6)
            ax.annotate(f"{name} = {value:.4f}", (1.0, value), xycoords=("axes fraction", "data"), xytext=(3, 0),
                        textcoords="offset points", va="center", fontsize=7)
        phi_l = f"φ$_L$ ≥ {PHI_TUNNELLED:.3f} (tunnelled crystals)" if monodisperse else "φ$_L$ (not measured)"
        ax.annotate(f"↓ {phi_l}", (0.02, 0.02), xycoords="axes fraction", fontsize=7)
        if monodisperse:
            ax.annotate(f"↑ φ$_{{max}}$ = φ$_{{HCP}}$ = {PHI_HCP:.4f}", (0.98, 0.97), xycoords="axes fraction",
                        fontsize=7, ha="right", va="top")
        ax.set_xscale("log")
        ax.set_xlim(lo_x, hi_x)
        ax.set_ylim(bottom, top)
        ax.set_xlabel("generation time: inverse compression rate 1/γ (LS scale)")
        ax.set_title(f"({letter}) σ = {s:g}{' (monodisperse)' if monodisperse else ''}", loc="left", fontsize=10)
        ax.legend(fontsize=7, loc="upper left")
    axes[0, 0].set_ylabel("closest jamming density φ$_J$")
    fig.tight_layout()
    return fig


def fig7(ds):
    """phi and phi_J vs sqrt(gamma) (linear axis) with the Table 2 cubic fits in black, extrapolated to gamma = 0;
    phi_GCP marked at the left edge."""
    plt = pyplot()
    t2 = compute_tables(ds)["table2"]
    sigmas = _sigmas(ds)
    col, mk = _colours(sigmas), _markers(sigmas)
    fig, axes = plt.subplots(2, 2, figsize=(10, 8), sharey="col")
    for ax, (label, protocol, var, _), letter in zip(axes.flat, PANEL_ROWS, "abcd"):
        for s in sigmas:
            m = _sel(ds, protocol, s)
            if not m.any():
                continue
            ax.plot(np.sqrt(ds.rate.values[m]), _values(ds, var)[m], mk[s], ms=4, mfc="none", color=col[s],
                    label=f"σ = {s:g}")
            row = t2[(t2.curve == label) & np.isclose(t2.sigma, s)] if len(t2) else t2
            if len(row) and np.isfinite(row.phi_gcp.iloc[0]):
                r = row.iloc[0]
                x = np.linspace(0, math.sqrt(1.0 / r.min_inverse_rate), 100)
                ax.plot(x, r.c0 + r.c1 * x + r.c2 * x**2 + r.c3 * x**3, "-", color="k", lw=1, zorder=1)
                _edge_mark(ax, r.phi_gcp, col[s], left=True)
        ax.set_xlim(left=0)
        ax.set_title(f"({letter}) {label}", loc="left", fontsize=10)
        ax.set_xlabel("√γ")
        ax.grid(alpha=0.3)
    return _finish_protocol_grid(fig, axes)


STRUCTURE_PANELS = (
    ("z_nonrattler", "non-rattler coordination Z"),
    ("rattler_fraction", "rattler fraction"),
    ("q6_local", "local Q6"),
    ("voronoi_volume_std", "Voronoi volume std / mean"),
    ("pore_size_entropy", "pore-size entropy"),
    ("calippso_delta_phi", "Δφ (CALiPPSO − MLS)"),
)


def structure(ds):
    """Structural measures of the jammed packings vs phi_J, sigma = 0, across compression rates."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(12, 7))
    m = _sel(ds, sigma=0.0) if np.isclose(ds.sigma.values, 0).any() else np.ones(ds.sizes["packing"], bool)
    for ax, (var, label) in zip(axes.flat, STRUCTURE_PANELS):
        if var in ds and np.isfinite(ds[var].values[m]).any():
            for protocol, mk in (("ls", "o"), ("fb", "s")):
                mm = m & (ds.protocol.values == protocol)
                sc = ax.scatter(ds.phi_J.values[mm], ds[var].values[mm], c=np.log10(ds.inverse_rate.values[mm]),
                                marker=mk, s=18, cmap="viridis", label=protocol.upper())
            fig.colorbar(sc, ax=ax, label="log10(1/γ)")
            if var == "z_nonrattler":
                ax.axhline(6.0, color="k", lw=0.8, ls="--")
            ax.legend(fontsize=7)
        else:
            _no_data(ax, f"{var} not in dataset")
        ax.set_xlabel("φ$_J$")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.suptitle("Structure of MLS packings, σ = 0")
    fig.tight_layout()
    return fig


def forces(ds):
    """Contact-force and gap distributions of the CALiPPSO-certified packings."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, var, xlabel, expo, symbol, mf in (
        (axes[0], "extended_force", "contact force f / <f>", "force_exponent", "θ_e", 0.42311),
        (axes[1], "gap", "gap h = r/D - 1", "gap_exponent", "γ", 0.41269),
    ):
        pdf, centres = f"{var}_pdf", f"{var.removeprefix('extended_')}_bin_centre"
        if pdf in ds and centres in ds.coords:
            labels = [f"σ = {s:g}" if np.isfinite(s) else str(key)
                      for key, s in zip(ds.dist_distribution.values, ds.dist_sigma.values)]
            if expo in ds:
                labels = [f"{label}: {symbol} = {v:.2f}" for label, v in zip(labels, ds[expo].values)]
                ax.set_title(f"fitted small-{var.split('_')[-1]} exponent {symbol} (mean field {mf})", fontsize=9)
            for k, label in enumerate(labels):
                y = ds[pdf].isel(dist_distribution=k).values
                ok = np.isfinite(y) & (y > 0)
                line, = ax.loglog(ds[centres].values[ok], y[ok], "o-", ms=3, label=label)
                if var == "extended_force" and "force_pdf" in ds:
                    y_all = ds["force_pdf"].isel(dist_distribution=k).values
                    ok = np.isfinite(y_all) & (y_all > 0)
                    ax.loglog(ds[centres].values[ok], y_all[ok], ":", color=line.get_color(),
                              label="all contacts" if k == 0 else None)
            ax.legend(fontsize=8)
        else:
            _no_data(ax, f"{var} distribution not in dataset")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("probability density")
    fig.tight_layout()
    return fig


def scaling(ds):
    """Finite-size scaling of the fast bands (docs/finite_size.md): per distribution and protocol, phi_J of the
    fast packings and their sample min/max against N^-1/2, the fitted mean and the expected min/max for the measured
    sample size, and the edges extrapolated to the paper's N = 10^4 (for its sample sizes, with 95 % bootstrap
    intervals) and to N -> infinity, beside the paper's values."""
    plt = pyplot()
    groups = fast_bands(ds) if len(sizes_in(ds)) > 1 else []
    if not groups:
        fig, ax = plt.subplots(figsize=(6.5, 3))
        _no_data(ax, "Finite-size scaling needs packings at 2 or more N:\n"
                     "give n as a ladder, e.g. n: [250, 500, 1000] (docs/finite_size.md)")
        ax.set_axis_off()
        return fig
    bands = band_settings(ds)
    alpha, conf = float(bands["alpha"]), float(bands["confidence"])
    paper, paper_min = paper_reference.table3(), paper_reference.table3_min_unattributed()
    fig, axes = plt.subplots(len(groups), 2, figsize=(9, 3.3 * len(groups)), squeeze=False)
    target = float(paper_reference.PAPER_N)
    for row, (group, by_protocol) in enumerate(groups):
        for col, protocol in enumerate(("ls", "fb")):
            ax = axes[row, col]
            samples = by_protocol[protocol]
            title = f"{protocol.upper()}, {_group_title(group)}"
            ax.set_title(title, fontsize=9)
            if len(samples) < 2:
                _no_data(ax, f"packings at {len(samples)} N: not estimable")
                continue
            _scaling_panel(ax, samples, protocol, group, alpha, conf, target, paper, paper_min)
    for ax in axes[-1]:
        ax.set_xlabel("N$^{-1/2}$")
    for ax in axes[:, 0]:
        ax.set_ylabel("φ$_J$ of fast compressions")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, ncol=3, loc="lower center", bbox_to_anchor=(0.5, 0.0))
    fig.tight_layout(rect=(0, 0.07 + 0.02 / len(groups), 1, 1))
    return fig


def _group_title(group: dict) -> str:
    return f"σ = {group['sigma']:g}" if math.isfinite(group["sigma"]) else str(group["distribution"])


def _scaling_panel(ax, samples, protocol, group, alpha, conf, target, paper, paper_min) -> None:
    ns = np.array(sorted(samples), dtype=float)
    for k, n in enumerate(ns):
        x = samples[int(n)]
        ax.plot(np.full(len(x), n**-0.5), x, ".", color="0.6", ms=3, label=None if k else "φ$_J$ of one packing")
        ax.plot([n**-0.5] * 2, [x.min(), x.max()], "_", color="k", ms=12, mew=1.5, ls="none",
                label=None if k else "sample min / max")
    fit = finite_size.fit_scaling(samples)
    size = int(np.median([len(samples[int(n)]) for n in ns]))
    grid = np.linspace(0.0, ns.min() ** -0.5 * 1.05, 100)
    with np.errstate(divide="ignore"):
        n_grid = np.where(grid > 0, grid ** -2.0, np.inf)
    ax.plot(grid, fit.mu_inf - fit.a * grid, "-", color="tab:blue", lw=1.2, label="fitted mean μ(N)")
    for side in finite_size.SIDES:
        expected = [fit.edge(n, side, "minmax", size, alpha) for n in n_grid]
        ax.plot(grid, expected, "--", color="tab:blue", lw=0.9,
                label=f"expected min / max of {size} packings" if side == "low" else None)
    paper_size = paper_reference.FAST_SAMPLE_SIZES[protocol]
    for side in finite_size.SIDES:
        [pred, limit] = finite_size.predict_edges(samples, [target, math.inf], side, "minmax", sample_size=paper_size,
                                                  alpha=alpha, confidence=conf)
        lo, hi = pred.interval
        ax.errorbar([target**-0.5], [pred.value], yerr=[[pred.value - lo], [hi - pred.value]], fmt="o",
                    color="tab:red", ms=5, capsize=3,
                    label="extrapolated to N = 10⁴ (expected min / max of the paper's 85 LS, 165 FB packings)"
                    if side == "low" else None)
        lo, hi = limit.interval
        ax.errorbar([0.0], [limit.value], yerr=[[limit.value - lo], [hi - limit.value]], fmt="D", color="tab:purple",
                    ms=4, capsize=3, label="N → ∞ (μ$_∞$)" if side == "low" else None)
    sigma = group["paper_sigma"]
    ref_max = paper_row(paper, sigma, protocol=protocol.upper())
    ref_min = paper_row(paper_min, sigma)
    for value, label in ((None if ref_min is None else float(ref_min.phi_min), "phi_min"),
                         (None if ref_max is None else float(ref_max.phi_max), "phi_max")):
        if value is not None:
            ax.plot([target**-0.5], [value], "*", color="tab:orange", ms=11, mec="k", mew=0.5,
                    label="paper (N = 10⁴)" if label == "phi_min" else None, gid=f"paper_{label}")
    ax.set_xlim(-0.002, grid[-1])
    ax.grid(alpha=0.3)


FIGURES = {"fig2": fig2, "fig3": fig3, "fig4": fig4, "fig5": fig5, "fig6": fig6, "fig7": fig7,
           "structure": structure, "forces": forces, "scaling": scaling,
           **container_figures.FIGURES}


#: Figures drawn per sigma of the ``sigmas`` runs (named distributions appear in Fig. 5, the tables and the force
#: figure).
PER_SIGMA = ("fig2", "fig4", "fig6", "fig7")


def draw(name: str, ds):
    """Figure ``name`` of a dataset. With packings at several N, every figure but ``scaling`` shows the largest N
    (the closest to the paper's), and says so in its lower right corner. With containers, the paper's figures show
    the packings of the reference container (:func:`~spherejam.workflow.dataset.reference_packings`: the periodic
    cube), and say so; the container figures show them all."""
    if name not in FIGURES:
        raise InputError(f"figure={name!r}: must be one of {', '.join(FIGURES)}")
    if name in container_figures.FIGURES:
        return FIGURES[name](ds)
    keys = container_keys(ds)
    if keys:
        ref = reference_packings(ds)
        fig = draw(name, ref.drop_vars([v for v in ref.variables if v.startswith(("container", "wall_", "profile_"))]))
        fig.text(0.005, 0.003, f"packings in {str(ref['container'].values[0])} "
                 f"({str(ref['container_spec'].values[0])}) only, of the containers {', '.join(keys)} (the others: "
                 "figures containers and profiles, and the tables)", ha="left", va="bottom", fontsize=7, color="0.35")
        return fig
    sizes = sizes_in(ds)
    if name != "scaling" and len(sizes) > 1:
        fig = draw(name, at_n(ds, sizes[-1]))
        fig.text(0.995, 0.003, f"N = {sizes[-1]} (largest of N = {', '.join(map(str, sizes))})", ha="right",
                 va="bottom", fontsize=7, color="0.35")
        return fig
    if name in PER_SIGMA and not _sigmas(ds):
        plt = pyplot()
        fig, ax = plt.subplots(figsize=(6.5, 3))
        _no_data(ax, f"{name} is drawn per σ of the log-normal sigmas runs; this experiment has none.\n"
                     "Its named distributions are in Fig. 5 and Tables 3-4.")
        ax.set_axis_off()
        return fig
    return FIGURES[name](ds)


def save_figure(fig, stem: str | os.PathLike, formats=("png", "pdf")) -> list[Path]:
    """Write ``stem.png`` and ``stem.pdf`` atomically."""
    plt = pyplot()
    out = []
    for ext in formats:
        path = Path(f"{stem}.{ext}")
        with atomic_output(path, f".{ext}") as tmp:
            fig.savefig(tmp, format=ext, dpi=150)
        out.append(path)
    plt.close(fig)
    return out


def _finish_protocol_grid(fig, axes):
    """Axis labels and legend of a 2 x 2 grid whose rows are LS and FB and whose right column holds phi_J."""
    for ax in axes[:, 0]:
        ax.set_ylabel("packing density φ")
    for ax in axes[:, 1]:
        ax.set_ylabel("closest jamming density φ$_J$")
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    return fig
