"""The paper's Figures 2-5 and 7, plus structure and contact-force figures, drawn from the results dataset alone.

Each ``fig*`` function takes the dataset and returns a matplotlib Figure; :func:`save_figure` writes PNG and PDF.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from .atomic import atomic_output
from .errors import InputError
from .tables import TABLE2_ROWS, completed_phi_J, compute_tables

#: Table 4 of the paper (N = 10^4) where legible, for comparison in Fig. 5. phi_GCP is the mean of the four
#: Table 2 rows of the paper (see shared/reference/algorithms.md Section 8.3); sigma = 0 takes 0.65.
PAPER_SIGMA = np.array([0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3])
PAPER_RCP = np.array([0.6405, 0.6421, 0.6440, 0.6486, 0.6542, 0.6600, 0.6676])
PAPER_GCP = np.array([0.65, 0.652625, 0.65535, 0.66045, 0.66540, 0.671575, 0.67850])


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _colours(sigmas):
    plt = _plt()
    cmap = plt.get_cmap("viridis")
    smax = max(max(sigmas), 1e-9)
    return {s: cmap(0.9 * s / smax) for s in sigmas}


def _no_data(ax, what="no data"):
    ax.text(0.5, 0.5, what, ha="center", va="center", transform=ax.transAxes, color="0.5")


def _sel(ds, protocol=None, sigma=None):
    mask = np.ones(ds.sizes["packing"], dtype=bool)
    if protocol is not None:
        mask &= ds.protocol.values == protocol
    if sigma is not None:
        mask &= np.isclose(ds.sigma.values, sigma)
    return mask


def fig2(ds):
    """phi and phi_J vs 1/gamma for LS and FB, with RCP (left) and GCP (right) marks."""
    plt = _plt()
    tables = compute_tables(ds)
    t2, t4 = tables["table2"], tables["table4"]
    sigmas = sorted(set(ds.sigma.values.tolist()))
    col = _colours(sigmas)
    fig, axes = plt.subplots(2, 2, figsize=(10, 8), sharey=True)
    panels = [("ls", "phi", "(a) LS, initial"), ("ls", "phi_J", "(b) LS, densified (MLS)"),
              ("fb", "phi", "(c) FB, initial"), ("fb", "phi_J", "(d) FB, densified (MLS)")]
    for ax, (protocol, var, title) in zip(axes.flat, panels):
        label = f"{protocol.upper()}, {'initial' if var == 'phi' else 'densified'}"
        for s in sigmas:
            m = _sel(ds, protocol, s)
            if m.any() and var in ds:
                y = completed_phi_J(ds) if var == "phi_J" else ds[var].values
                ax.plot(ds.inverse_rate.values[m], y[m], "o", ms=4, color=col[s], label=f"σ = {s:g}")
            rcp = t4.loc[np.isclose(t4.sigma, s), "phi_RCP"]
            if len(rcp) and np.isfinite(rcp.iloc[0]):
                ax.axhline(rcp.iloc[0], xmin=0, xmax=0.06, color=col[s], lw=2)
            gcp = t2.loc[(t2.curve == label) & np.isclose(t2.sigma, s), "phi_gcp"]
            gval = 0.65 if s == 0 else (gcp.iloc[0] if len(gcp) else math.nan)
            if np.isfinite(gval):
                ax.axhline(gval, xmin=0.94, xmax=1, color=col[s], lw=2)
        ax.set_xscale("log")
        ax.set_title(title, loc="left", fontsize=10)
        ax.set_xlabel("inverse compression rate 1/γ")
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("packing fraction φ")
    axes[1, 0].set_ylabel("packing fraction φ")
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    return fig


def fig3(ds):
    """phi_J of the validation grid vs 1/gamma, coloured by (a) decrease factor, (b) initial rate."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    if "grid_run" not in ds.dims:
        for ax in axes:
            _no_data(ax, "validation grid disabled in this experiment")
        return fig
    markers = {s: m for s, m in zip(sorted(set(ds.grid_sigma.values.tolist())), "osD^v")}
    grid_phi_j = ds.grid_phi_J.values.astype(float).copy()
    if "grid_completed" in ds:
        grid_phi_j[ds.grid_completed.values != 1] = np.nan  # cut MLS run: not a closest-jamming density
    for ax, key, title in ((axes[0], "decrease_factor", "(a) decrease factor"),
                           (axes[1], "initial_rate", "(b) initial rate")):
        values = sorted(set(ds[key].values.tolist()))
        cmap = plt.get_cmap("plasma")
        for k, v in enumerate(values):
            for s, mk in markers.items():
                m = (ds[key].values == v) & np.isclose(ds.grid_sigma.values, s)
                # a small horizontal offset per parameter keeps overlapping points visible
                x = ds.grid_inverse_rate.values[m] * 1.06 ** (k - len(values) / 2)
                colour = cmap(0.85 * k / max(len(values) - 1, 1))
                ax.plot(x, grid_phi_j[m], mk, ms=5, mfc="none", color=colour, label=f"{v:g} (σ = {s:g})")
        ax.set_xscale("log")
        ax.set_xlabel("inverse compression rate 1/γ of the LS packing")
        ax.set_title(title, loc="left", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
    axes[0].set_ylabel("closest jamming density φ_J")
    fig.tight_layout()
    return fig


def fig4(ds):
    """Number distributions of phi_J for fast compressions, (a) LS and (b) FB."""
    from .dataset import dataset_config

    plt = _plt()
    fast = {"ls_max_inverse_rate": 5.0, "fb_max_inverse_rate": 1000.0, **dataset_config(ds).get("fast", {})}
    sigmas = sorted(set(ds.sigma.values.tolist()))
    col = _colours(sigmas)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, protocol, title in ((axes[0], "ls", "(a) LS, 1/γ < {:g}"), (axes[1], "fb", "(b) FB, 1/γ < {:g}")):
        limit = fast[f"{protocol}_max_inverse_rate"]
        phi_j = completed_phi_J(ds)
        values = [phi_j[_sel(ds, protocol, s) & (ds.inverse_rate.values < limit)] for s in sigmas]
        allv = np.concatenate(values) if values else np.array([])
        allv = allv[np.isfinite(allv)]
        if len(allv) == 0:
            _no_data(ax, "no fast compressions")
        else:
            bins = np.linspace(allv.min() - 1e-3, allv.max() + 1e-3, 30)
            for s, v in zip(sigmas, values):
                v = v[np.isfinite(v)]
                if len(v):
                    ax.hist(v, bins=bins, color=col[s], alpha=0.7, label=f"σ = {s:g} ({len(v)})")
            ax.legend(fontsize=8)
        ax.set_title(title.format(limit), loc="left", fontsize=10)
        ax.set_xlabel("closest jamming density φ_J")
    axes[0].set_ylabel("number of packings")
    fig.tight_layout()
    return fig


def fig5(ds):
    """phi_LT, phi_RCP and phi_GCP vs sigma (Table 4), with the paper's N = 10^4 values."""
    plt = _plt()
    t4 = compute_tables(ds)["table4"]
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(t4.sigma, t4.phi_LT, "o", color="tab:red", mfc="none", label="φ_LT (this run)")
    ax.plot(t4.sigma, t4.phi_RCP, "+", color="m", ms=9, label="φ_RCP (this run)")
    ax.plot(t4.sigma, t4.phi_GCP, "x", color="c", ms=8, label="φ_GCP (this run)")
    ax.plot(PAPER_SIGMA, PAPER_RCP, "--", color="m", lw=1, label="φ_RCP, paper (N = 10⁴)")
    ax.plot(PAPER_SIGMA, PAPER_GCP, ":", color="c", lw=1, label="φ_GCP, paper (N = 10⁴)")
    ax.set_xlabel("relative standard deviation σ of the diameters")
    ax.set_ylabel("packing fraction")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def fig7(ds):
    """phi and phi_J vs sqrt(gamma) with the Table 2 cubic fits extrapolated to gamma = 0."""
    plt = _plt()
    t2 = compute_tables(ds)["table2"]
    sigmas = [s for s in sorted(set(ds.sigma.values.tolist())) if s > 0]
    col = _colours(sorted(set(ds.sigma.values.tolist())))
    fig, axes = plt.subplots(2, 2, figsize=(10, 8), sharey=True)
    for ax, (label, protocol, var, _) in zip(axes.flat, TABLE2_ROWS):
        for s in sigmas:
            m = _sel(ds, protocol, s)
            y = completed_phi_J(ds) if var == "phi_J" else ds[var].values
            ax.plot(np.sqrt(ds.rate.values[m]), y[m], "o", ms=3, color=col[s], label=f"σ = {s:g}")
            row = t2[(t2.curve == label) & np.isclose(t2.sigma, s)]
            if len(row) and np.isfinite(row.phi_gcp.iloc[0]):
                r = row.iloc[0]
                x = np.linspace(0, math.sqrt(1.0 / r.min_inverse_rate), 100)
                ax.plot(x, r.c0 + r.c1 * x + r.c2 * x**2 + r.c3 * x**3, "-", color=col[s], lw=1)
                ax.plot([0], [r.phi_gcp], "s", color=col[s])
        ax.set_title(label, loc="left", fontsize=10)
        ax.set_xlabel("√γ")
        ax.set_xscale("symlog", linthresh=1e-2)
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("packing fraction φ")
    axes[1, 0].set_ylabel("packing fraction φ")
    if sigmas:
        axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    return fig


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
    plt = _plt()
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
        ax.set_xlabel("φ_J")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.suptitle("Structure of MLS packings, σ = 0")
    fig.tight_layout()
    return fig


def forces(ds):
    """Contact-force and gap distributions of the CALiPPSO-certified packings."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, var, xlabel, expo, symbol, mf in (
        (axes[0], "extended_force", "contact force f / <f>", "force_exponent", "θ_e", 0.42311),
        (axes[1], "gap", "gap h = r/D - 1", "gap_exponent", "γ", 0.41269),
    ):
        pdf, centres = f"{var}_pdf", f"{var.removeprefix('extended_')}_bin_centre"
        if pdf in ds and centres in ds.coords:
            for k, s in enumerate(ds.dist_sigma.values):
                y = ds[pdf].sel(dist_sigma=s).values
                ok = np.isfinite(y) & (y > 0)
                line, = ax.loglog(ds[centres].values[ok], y[ok], "o-", ms=3, label=f"σ = {s:g}")
                if var == "extended_force" and "force_pdf" in ds:
                    y_all = ds["force_pdf"].sel(dist_sigma=s).values
                    ok = np.isfinite(y_all) & (y_all > 0)
                    ax.loglog(ds[centres].values[ok], y_all[ok], ":", color=line.get_color(),
                              label="all contacts" if k == 0 else None)
            if expo in ds:
                txt = ", ".join(f"{v:.2f}" for v in ds[expo].values)
                ax.set_title(f"fitted {symbol} per σ: {txt} (mean field {mf})", fontsize=9)
            ax.legend(fontsize=8)
        else:
            _no_data(ax, f"{var} distribution not in dataset")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("probability density")
    fig.tight_layout()
    return fig


FIGURES = {"fig2": fig2, "fig3": fig3, "fig4": fig4, "fig5": fig5, "fig7": fig7, "structure": structure,
           "forces": forces}


def draw(name: str, ds):
    if name not in FIGURES:
        raise InputError(f"figure={name!r}: must be one of {', '.join(FIGURES)}")
    return FIGURES[name](ds)


def save_figure(fig, stem: str | os.PathLike, formats=("png", "pdf")) -> list[Path]:
    """Write ``stem.png`` and ``stem.pdf`` atomically."""
    plt = _plt()
    out = []
    for ext in formats:
        path = Path(f"{stem}.{ext}")
        with atomic_output(path, f".{ext}") as tmp:
            fig.savefig(tmp, format=ext, dpi=150)
        out.append(path)
    plt.close(fig)
    return out
