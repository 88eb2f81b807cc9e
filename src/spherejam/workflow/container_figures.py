"""The figures of an experiment with containers (docs/containers.md), drawn from the results dataset alone.

* ``containers``: the closest jamming density phi_J against the achieved D/<d> of every cylinder, beside the bulk
  (the periodic cube) and the packed-bed correlations of :mod:`spherejam.analysis.packed_bed`; below, the excess
  porosity over bulk, each with its own bulk, which is what compares (frictionless jammed packings are denser than
  poured beds). Only correlations whose formulas were read in their papers are drawn (``verified``).
* ``profiles``: the porosity profile from the wall (radial in a cylinder or a sphere, from the nearer wall in a
  slab or a box), the mean over each container's jammed packings, exact sphere-shell volumes
  (:mod:`spherejam.analysis.profiles`), with the bulk porosity.

Only packings whose MLS run completed are drawn (``mls_completed``), as in the tables.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import InputError
from .dataset import container_keys, with_distributions
from .plotting import pyplot
from .tables import completed_phi_J

#: Figures of an experiment with containers (part of ``all`` only when it has a container other than the cube).
CONTAINER_FIGURES = ("containers", "profiles")
PROTOCOL_MARKERS = {"ls": "o", "fb": "s"}


def _no_containers(name: str):
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 2.5))
    ax.text(0.5, 0.5, f"{name}: this experiment has no container with walls (containers: in its config)",
            ha="center", va="center", transform=ax.transAxes, color="0.5")
    ax.set_axis_off()
    return fig


def _specs(ds) -> dict[str, str]:
    return dict(zip((str(k) for k in ds["container"].values), (str(s) for s in ds["container_spec"].values)))


def _mean_ci(values: np.ndarray) -> tuple[float, float]:
    """Mean and the half-width of its 95 % t interval (NaN with fewer than 2 values)."""
    from scipy import stats

    v = values[np.isfinite(values)]
    if len(v) == 0:
        return math.nan, math.nan
    if len(v) < 2:
        return float(v.mean()), math.nan
    return float(v.mean()), float(stats.t.ppf(0.975, len(v) - 1) * v.std(ddof=1) / math.sqrt(len(v)))


def containers(ds):
    """phi_J against D/<d> in cylinders beside the bulk and the packed-bed correlations, and the excess porosity."""
    from ..analysis.packed_bed import CORRELATIONS, correlation_excess, mean_porosity

    if not container_keys(ds):
        return _no_containers("containers")
    ds = with_distributions(ds)
    plt = pyplot()
    specs = _specs(ds)
    phi_j = completed_phi_J(ds)
    container = ds["container"].values.astype(str)
    protocol = ds["protocol"].values.astype(str)
    dist = ds["distribution"].values.astype(str)
    size = ds["container_size"].values.astype(float)
    shape = ds["container_shape"].values.astype(str)
    cylinders = [k for k in container_keys(ds) if specs[k].startswith("cylinder")]
    bulk_keys = [k for k in container_keys(ds) if specs[k] == "periodic"]
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(6.8, 7.4), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    dists = list(dict.fromkeys(dist.tolist()))
    colours = {d: plt.get_cmap("tab10")(i % 10) for i, d in enumerate(dists)}
    xs = size[(shape == "cylinder") & np.isfinite(size)]
    x_hi = max(float(xs.max()) * 1.15 if xs.size else 12.0, 12.0)
    bulk_phi: dict[tuple[str, str], float] = {}
    for d in dists:
        for p in ("ls", "fb"):
            sel = np.isin(container, bulk_keys) & (protocol == p) & (dist == d)
            mean, half = _mean_ci(phi_j[sel])
            bulk_phi[d, p] = mean
            if math.isfinite(mean):
                ax.axhline(mean, color=colours[d], lw=0.8, ls=":" if p == "fb" else "-.",
                           label=f"bulk ({p.upper()}, {d}): {mean:.4f}")
                if math.isfinite(half):
                    ax.axhspan(mean - half, mean + half, color=colours[d], alpha=0.08, lw=0)
    drawn = False
    ours_phi, ours_excess = [v for v in bulk_phi.values() if math.isfinite(v)], [0.0]
    labelled: set[tuple[str, str]] = set()  # one legend entry per distribution and protocol
    for k in cylinders:
        for d in dists:
            for p in ("ls", "fb"):
                sel = (container == k) & (protocol == p) & (dist == d) & np.isfinite(phi_j)
                if not sel.any():
                    continue
                drawn = True
                x = size[sel]
                ax.plot(x, phi_j[sel], PROTOCOL_MARKERS[p], color=colours[d], alpha=0.35, ms=4, mew=0)
                m, h = _mean_ci(phi_j[sel])
                ax.errorbar([x.mean()], [m], yerr=[h if math.isfinite(h) else 0.0], fmt=PROTOCOL_MARKERS[p],
                            color=colours[d], mec="k", mew=0.6, ms=7, capsize=3)
                ours_phi += phi_j[sel].tolist()
                if math.isfinite(bulk_phi[d, p]):
                    ours_excess.append(bulk_phi[d, p] - m)
                if math.isfinite(bulk_phi[d, p]):  # excess porosity: eps - eps_bulk = phi_bulk - phi
                    ax2.errorbar([x.mean()], [bulk_phi[d, p] - m], yerr=[h if math.isfinite(h) else 0.0],
                                 fmt=PROTOCOL_MARKERS[p], color=colours[d], mec="k", mew=0.6, ms=7, capsize=3,
                                 label=None if (d, p) in labelled else f"ours, {p.upper()} + MLS, {d}")
                    labelled.add((d, p))
    x_lo = 2.5
    grid = np.linspace(x_lo, x_hi, 200)
    verified = [n for n, c in CORRELATIONS.items() if c.kind == "mean" and c.verified]
    reference = [1.0 - mean_porosity(n, grid[grid > CORRELATIONS[n].ratio_range[0]]) for n in verified]
    reference_excess = [correlation_excess(n, grid[grid > CORRELATIONS[n].ratio_range[0]]) for n in verified]
    # only correlations whose formulas were checked against their papers (analysis/packed_bed.py): a formula not
    # read from its paper is no yardstick, even drawn apart
    for name, c in CORRELATIONS.items():
        if c.kind != "mean" or not c.verified:
            continue
        lo, hi = c.ratio_range
        r = grid[(grid > lo) & (grid <= hi)]
        label = c.reference.split(",")[0].split(" (")[0] + " " + c.reference.split("(")[-1].split(")")[0][-4:]
        ax.plot(r, 1.0 - mean_porosity(name, r), color="k", lw=1.4, label=f"{label}: poured beds")
        ax2.plot(r, correlation_excess(name, r), color="k", lw=1.4, label=label)
    if not drawn:
        ax.text(0.5, 0.5, "no cylinder with completed MLS runs", ha="center", va="center", transform=ax.transAxes,
                color="0.5")
    # the axes fit our packings and the correlations
    lows = [min(ours_phi, default=0.6)] + [float(r.min()) for r in reference]
    highs = [max(ours_phi, default=0.6)] + [float(r.max()) for r in reference]
    ax.set_ylim(max(min(lows) - 0.02, 0.0), min(max(highs) + 0.02, 0.75))
    ax2.set_ylim(min(min(ours_excess), 0.0) - 0.02,
                 max([max(ours_excess)] + [float(r.max()) for r in reference_excess]) + 0.03)
    ax.set_ylabel("closest jamming density φ$_J$ (1 − ε)")
    ax.set_title("Packed columns: φ$_J$ against D/⟨d⟩ (points: packings; large: mean ± 95 % CI)", fontsize=9)
    ax.legend(fontsize=6.5, loc="lower right")
    ax.grid(alpha=0.3)
    ax2.set_xlabel("D/⟨d⟩ (achieved, jammed packing)")
    ax2.set_ylabel("excess porosity ε − ε$_{bulk}$")
    ax2.axhline(0.0, color="0.6", lw=0.6)
    ax2.set_xlim(x_lo, x_hi)
    ax2.legend(fontsize=6.5, loc="upper right")
    ax2.grid(alpha=0.3)
    fig.text(0.01, 0.005, "each with its own bulk: ours the periodic cube of the same protocol, a correlation its "
             "D/d → ∞ limit; the correlations are for equal spheres", fontsize=6.5, color="0.35")
    fig.tight_layout(rect=(0, 0.015, 1, 1))
    return fig


def profiles(ds):
    """The mean porosity profile from the wall of each container with walls, with the bulk porosity."""
    from ..analysis.packed_bed import CORRELATIONS, radial_porosity

    keys = container_keys(ds)
    specs = _specs(ds) if keys else {}
    walled = [k for k in keys if specs[k] != "periodic" and not specs[k].startswith("periodic:")]
    if not walled or "profile_porosity" not in ds:
        return _no_containers("profiles")
    plt = pyplot()
    completed = np.isfinite(completed_phi_J(ds))
    container = ds["container"].values.astype(str)
    distance = ds["wall_distance"].values.astype(float)
    table = ds["profile_porosity"].values.astype(float)
    size = ds["container_size"].values.astype(float)
    bulk = completed & np.isin(container, [k for k in keys if specs[k] == "periodic"])
    eps_bulk = 1.0 - float(np.nanmean(completed_phi_J(ds)[bulk])) if bulk.any() else math.nan
    fig, axes = plt.subplots(len(walled), 1, figsize=(6.8, 2.3 * len(walled) + 0.6), squeeze=False)
    for ax, k in zip(axes[:, 0], walled):
        sel = completed & (container == k)
        rows = table[sel]
        if rows.size == 0 or not np.isfinite(rows).any():
            ax.text(0.5, 0.5, f"{k}: no profile (no completed MLS run, or the analysis is off)", ha="center",
                    va="center", transform=ax.transAxes, color="0.5")
            continue
        counts = np.isfinite(rows).sum(axis=0)
        keep = counts > 0
        mean = np.nanmean(rows[:, keep], axis=0)
        ax.plot(distance[keep], mean, color="tab:blue", lw=1.2,
                label=f"ours: mean of {int(sel.sum())} jammed packings")
        if math.isfinite(eps_bulk):
            ax.axhline(eps_bulk, color="0.3", lw=0.8, ls="-.", label=f"bulk ε = {eps_bulk:.3f} (periodic cube)")
        ratio = float(np.nanmean(size[sel]))
        if specs[k].startswith("cylinder") and math.isfinite(ratio):
            for name, c in CORRELATIONS.items():
                if c.kind != "radial" or not c.verified:  # as in the containers figure
                    continue
                try:
                    eps = radial_porosity(name, distance[keep], ratio)
                except InputError:
                    continue
                ax.plot(distance[keep], eps, color="k", lw=1.0, label=c.reference.split(",")[0])
        where = "radial, from the wall" if specs[k].startswith(("cylinder", "sphere")) else "from the nearer wall"
        ax.set_title(f"{k}: {specs[k]} (achieved D/⟨d⟩ = {ratio:.2f}); {where}" if math.isfinite(ratio)
                     else f"{k}: {specs[k]}; {where}", fontsize=8.5)
        ax.set_ylim(0.0, 1.02)
        ax.set_xlim(0.0, float(distance[keep].max()) + 0.05)
        ax.set_ylabel("porosity ε")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5, loc="upper right")
    axes[-1, 0].set_xlabel("distance from the wall (mean diameters)")
    fig.tight_layout()
    return fig


FIGURES = {"containers": containers, "profiles": profiles}
