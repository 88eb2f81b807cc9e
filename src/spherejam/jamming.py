"""One call from a size distribution to a jammed packing: :func:`jam` and its :class:`JamResult` (docs/python.md).

:func:`jam` composes the pipeline's steps as the workflow runs them (README, "What it does"): Poisson seeding
(:func:`~spherejam.core.seeding.poisson_packing`), generation by LS (:func:`~spherejam.engines.lubachevsky_stillinger.
run_ls`) or FB (:func:`~spherejam.engines.force_biased.run_fb`), the closest jamming search MLS
(:func:`~spherejam.engines.closest_jamming.find_closest_jamming`) and CALiPPSO certification
(:func:`~spherejam.calippso.run.run_calippso`). Every argument after ``psd`` is keyword-only. ``container`` packs in
a slab, a box, a cylinder or a sphere (docs/containers.md) instead of the periodic cube.

Seeds: the one ``seed`` is split by numpy's SeedSequence into the seeding, generation and MLS streams, so the same
arguments give bitwise the same packing.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .core.errors import require

if TYPE_CHECKING:  # the engines pull in numba: imported when jam() runs, not with `import spherejam`
    from .calippso.run import CalippsoResult
    from .core.packing import Packing
    from .engines.result import RunResult

PROTOCOLS = ("ls", "fb")
#: The paper's fast rates used when ``rate`` is not given (1/gamma inside Table 3's fast range for each protocol).
DEFAULT_RATE = {"ls": 0.3, "fb": 0.002}
#: The workflow's nominal density: the side L of the periodic cube at which the nominal diameters fill this fraction.
DEFAULT_PHI_NOMINAL = 0.6


@dataclass(frozen=True)
class JamResult:
    """The outcome of :func:`jam`.

    Attributes
    ----------
    packing : Packing
        The final packing, ACTUAL diameters in a periodic cube of side ``packing.box``: the MLS output with
        ``closest``, else the generation's output.
    phi : float
        Packing fraction of the generation's output (LS or FB), dimensionless.
    phi_J : float or None
        Packing fraction of the closest jammed packing MLS found (None without ``closest``).
    pressure : float or None
        Reduced pressure p = PV/(N k_B T) of the last LS/MLS window (None for FB without ``closest``: FB has no
        pressure).
    stop_reason : str
        Why the last engine run stopped (``p_max``, ``converged``, ``max_collisions``, ...:
        :data:`spherejam.engines.result.STOP_REASONS`).
    certificate : CalippsoResult or None
        The CALiPPSO run with ``certify``: its ``isostatic``, ``n_contacts``, ``rattlers``, ``forces``,
        ``force_balance_residual`` and its own jammed ``packing``.
    provenance : dict
        The call's arguments, the seeds each step used, spherejam's version, git commit, package versions, time.
    runs : dict of RunResult
        ``"generation"`` and, with ``closest``, ``"closest"``: each run's per-window history and statistics.
    """

    packing: Packing
    phi: float
    phi_J: float | None
    pressure: float | None
    stop_reason: str
    certificate: CalippsoResult | None
    provenance: dict[str, Any]
    runs: dict[str, RunResult] = field(repr=False)

    def __repr__(self) -> str:
        phi_j = "None" if self.phi_J is None else f"{self.phi_J:.6f}"
        cert = "None" if self.certificate is None else (
            f"{'isostatic' if self.certificate.isostatic else 'NOT isostatic'}, {self.certificate.stop_reason}")
        p = "None" if self.pressure is None else f"{self.pressure:.3g}"
        return (f"JamResult(N={self.packing.n}, phi={self.phi:.6f}, phi_J={phi_j}, pressure={p}, "
                f"stop_reason={self.stop_reason!r}, certificate={cert})")

    def _sphere_columns(self) -> dict[str, np.ndarray]:
        p = self.packing
        cols = {axis: p.positions[:, k] for k, axis in enumerate("xyzuv"[: p.dim])}
        cols["diameter"] = p.diameters
        if self.certificate is not None:  # the certificate's contact network, of its own (a touch denser) packing
            c = self.certificate
            contacts = np.bincount(c.pairs[:, 0], minlength=p.n) + np.bincount(c.pairs[:, 1], minlength=p.n)
            contacts += np.bincount(c.wall_contacts, minlength=p.n)  # a container's walls (none in a periodic box)
            cols["contacts"] = contacts.astype(np.int64)
            cols["rattler"] = np.asarray(c.rattlers, dtype=bool)
        return cols

    def summary(self) -> dict[str, Any]:
        """The scalars: N, d, L, phi, phi_J, pressure, stop reason and, with a certificate, its verdict."""
        out = {"n": self.packing.n, "dim": self.packing.dim, "box": self.packing.box, "phi": self.phi,
               "phi_J": self.phi_J, "pressure": self.pressure, "stop_reason": self.stop_reason}
        if self.certificate is not None:
            c = self.certificate
            out.update(certified_isostatic=bool(c.isostatic), calippso_stop_reason=c.stop_reason,
                       calippso_phi=float(c.phi), n_contacts=int(c.n_contacts), n_rattlers=int(c.n_rattlers),
                       force_balance_residual=float(c.force_balance_residual))
        return out

    def to_pandas(self):
        """One row per sphere: centre coordinates (x, y, z), actual diameter and, with a certificate, its contacts
        and rattler flag; the scalars of :meth:`summary` in ``DataFrame.attrs``."""
        import pandas as pd

        df = pd.DataFrame(self._sphere_columns())
        df.index.name = "sphere"
        df.attrs.update(self.summary())
        return df

    def to_xarray(self):
        """An xarray Dataset: ``position (sphere, axis)``, ``diameter (sphere)`` (and ``contacts``, ``rattler``
        with a certificate); the scalars of :meth:`summary` and the provenance (JSON) as attributes, None left
        out (netCDF has no null attribute)."""
        import xarray as xr

        cols = self._sphere_columns()
        axes = list("xyzuv"[: self.packing.dim])
        data = {"position": (("sphere", "axis"), self.packing.positions, {"units": "mean nominal diameter"}),
                "diameter": ("sphere", cols["diameter"], {"units": "mean nominal diameter"})}
        for name in ("contacts", "rattler"):
            if name in cols:
                data[name] = ("sphere", cols[name].astype(np.int8) if name == "rattler" else cols[name])
        attrs = {k: (int(v) if isinstance(v, bool) else v) for k, v in self.summary().items() if v is not None}
        attrs["provenance"] = json.dumps(self.provenance, default=str)
        return xr.Dataset(data, coords={"sphere": np.arange(self.packing.n), "axis": axes}, attrs=attrs)


def _options(value: bool | Mapping[str, Any], name: str) -> dict[str, Any] | None:
    if isinstance(value, Mapping):
        return dict(value)
    require(isinstance(value, (bool, np.bool_)), name, value, "must be True, False or a dict of options")
    return {} if value else None


def _seeds(seed: int) -> tuple[int, int, int]:
    """Independent seeds (0 <= s < 2^63) of the seeding, generation and MLS streams from one master seed."""
    state = np.random.SeedSequence(seed).generate_state(3, dtype=np.uint64)
    return tuple(int(s >> np.uint64(1)) for s in state)


def jam(
    n: int | None = 1000,
    psd: str = "lognormal:sigma=0",
    *,
    protocol: str = "ls",
    rate: float | None = None,
    closest: bool | Mapping[str, Any] = True,
    certify: bool | Mapping[str, Any] = False,
    seed: int = 0,
    box: float | None = None,
    container: str | None = None,
    p_max: float = 1e12,
    progress: bool = False,
) -> JamResult:
    """A jammed packing of ``n`` spheres with size distribution ``psd``, in one call.

    Parameters
    ----------
    n : int or None
        Number of spheres N >= 2 (None: taken from a ``list:`` distribution).
    psd : str
        The size distribution (docs/psd.md): ``lognormal:sigma=0.3`` (the paper's), ``gaussian:delta=0.2``,
        ``bidisperse:ratio=1.4,small=0.5,by=number``, ``table:powder.csv``...; mean diameter 1.
    protocol : "ls" or "fb"
        The generation: Lubachevsky-Stillinger compression to ``p_max``, or the force-biased algorithm.
    rate : float, optional
        Compression rate gamma: LS's d rho / dt (default 0.3) or FB's contraction per iteration (default 0.002).
    closest : bool or dict
        Run the closest-jamming search MLS on the generation's output (True: the paper's parameters, gamma from
        10 halved down to 1e-4; a dict passes options to ``find_closest_jamming``, e.g. ``{"final_rate": 1e-2}``
        for a quicker, less converged phi_J).
    certify : bool or dict
        Certify the final packing with CALiPPSO (a dict passes options to ``run_calippso``).
    seed : int
        Master seed, 0 <= seed < 2^63: the same arguments and seed give the same packing.
    box : float, optional
        Side L of the periodic cube, in units of the mean nominal diameter (default: the side at which the nominal
        diameters fill 0.6 of it, as in the workflow's configs). The same as a nominal density phi_nominal = (sum of
        nominal sphere volumes) / L^3: it sets how sparse the seeded start is; the engines rescale the diameters.
    container : str, optional
        A container spec (docs/containers.md): ``cylinder:diameter=10`` (a column, D/<d> = 10, its length from N),
        ``slab:height=8``, ``box:x=10,y=10,z=10``, ``sphere:diameter=12`` (N from its size: ``n=None``),
        ``periodic:x=10,y=10,z=40``; lengths in mean diameters of the final packing, the achieved ones in
        ``result.packing.container.in_diameters(result.packing.mean_diameter)``. Not with ``box``; ``certify``
        certifies in the container (its wall rows and isostatic count: docs/containers.md §5).
    p_max : float
        LS stops when the reduced pressure reaches this (the paper's 1e12).
    progress : bool
        Log the engines' progress lines (logger ``spherejam``, INFO).

    Returns
    -------
    JamResult
    """
    from .calippso.run import run_calippso
    from .core.packing import Packing, ball_volume
    from .core.provenance import provenance
    from .core.seeding import poisson_packing
    from .core.validation import FIELDS
    from .engines.closest_jamming import find_closest_jamming
    from .engines.force_biased import run_fb
    from .engines.lubachevsky_stillinger import run_ls

    require(protocol in PROTOCOLS, "protocol", protocol, f"must be one of {', '.join(PROTOCOLS)}")
    FIELDS["seed"].check("seed", seed)
    mls_options, calippso_options = _options(closest, "closest"), _options(certify, "certify")
    rate = DEFAULT_RATE[protocol] if rate is None else rate
    quiet = {} if progress else {"progress_interval": 1e9}  # no progress line within any run
    seeds = _seeds(seed)
    if box is not None:
        require(isinstance(box, (int, float, np.floating)) and math.isfinite(box) and box > 0, "box", box,
                "must be a finite number > 0 (the side L of the periodic cube)")

    if container is not None:
        require(box is None, "box", box, "must be left out with a container (the container sets the size)")
        start = poisson_packing(n, psd=psd, seed=seeds[0], container=container)
    else:
        start = poisson_packing(n, psd=psd, seed=seeds[0], phi_nominal=DEFAULT_PHI_NOMINAL)
    if box is not None:
        nominal = start.nominal_diameters
        phi_nominal = float(np.sum(ball_volume(nominal, start.dim)) / box**start.dim)
        metadata = dict(start.metadata, parameters={**start.metadata["parameters"], "phi_nominal": phi_nominal})
        # uniform centres in [0, L0) scaled by L/L0 are uniform in [0, L): the same draw in the asked box
        start = Packing(start.positions * (box / start.box), nominal, float(box), metadata).scaled_to_contact()

    if protocol == "ls":
        generation = run_ls(start, rate, p_max=p_max, seed=seeds[1], **quiet)
    else:
        generation = run_fb(start, rate, **quiet)
    runs = {"generation": generation}
    final = generation
    if mls_options is not None:
        final = runs["closest"] = find_closest_jamming(generation.packing, seed=seeds[2],
                                                       **{**quiet, **mls_options})
    certificate = None
    if calippso_options is not None:
        certificate = run_calippso(final.packing, **{**quiet, **calippso_options})

    pressure = final.packing.metadata.get("reduced_pressure")
    pressure = float(pressure) if pressure is not None and math.isfinite(float(pressure)) else None
    call = {"n": n, "psd": psd, "protocol": protocol, "rate": rate, "closest": closest, "certify": certify,
            "seed": seed, "box": box, "container": container, "p_max": p_max}
    return JamResult(
        packing=final.packing,
        phi=float(generation.packing.phi),
        phi_J=float(final.packing.phi) if mls_options is not None else None,
        pressure=pressure,
        stop_reason=final.stats.stop_reason,
        certificate=certificate,
        provenance={"call": call, "seeds": {"seeding": seeds[0], "generation": seeds[1], "closest": seeds[2]},
                    "box": float(start.box), "container": start.container.spec, **provenance()},
        runs=runs,
    )
