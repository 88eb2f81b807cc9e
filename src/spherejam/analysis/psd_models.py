"""Published estimates of the jamming density of polydisperse spheres from the size distribution alone.

Each model is a plain function of descriptors (:mod:`spherejam.core.size_distribution`) with its citation and the
range its authors fitted or tested it on; :func:`predictions` evaluates all three for one distribution, each flagged
when the distribution lies outside that range. docs/psd.md compares them with our measurements.

* **Farr & Groot** (J. Chem. Phys. 131, 244104, 2009): a 1D rod-packing model of any PSD; our reconstruction
  (:mod:`spherejam.analysis.farr_groot`, docs/farr_groot.md), calibrated to phi = 0.6435 for equal spheres. The
  authors state an accuracy of about 0.01 against 3D simulations of bidisperse (size ratio up to 10), tridisperse
  and log-normal mixtures.
* **Desmond & Weeks** (Phys. Rev. E 90, 022204, 2014): an empirical fit of their simulated phi_RCP,
  phi_RCP = 0.634 + 0.0658 delta + 0.0857 S delta^2 (delta = relative std of the radius = of the diameter,
  S = skewness), over several distribution families with delta <= 0.4.
* **Santos, Yuste, Lopez de Haro, Odriozola & Ogarko** (Phys. Rev. E 89, 040302(R), 2014): phi_J depends on the
  distribution through z = M2^2/(M1 M3) only: phi_J / (1 - phi_J) = [phi_mono / (1 - phi_mono)] / z, i.e.
  phi_J = phi_mono / (phi_mono + (1 - phi_mono) z). Its one input phi_mono, the monodisperse jamming density, is
  **ours** (the phi_RCP we measure at sigma = 0, or the paper's 0.6405 when none is measured), so it predicts how
  polydispersity shifts our own phi_RCP.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The paper's (Baranau & Tallarek 2014, Table 4) monodisperse phi_RCP, N = 10^4: Santos' input when none is measured.
PHI_RCP_MONO_PAPER = 0.6405

#: phi_RCP of Desmond & Weeks' fit for equal spheres and its two coefficients.
DW_PHI0, DW_C1, DW_C2 = 0.634, 0.0658, 0.0857
#: Largest delta Desmond & Weeks fitted.
DW_DELTA_MAX = 0.4

CITATIONS = {
    "farr_groot": "Farr & Groot, J. Chem. Phys. 131, 244104 (2009); our reconstruction (docs/farr_groot.md)",
    "desmond_weeks": "Desmond & Weeks, Phys. Rev. E 90, 022204 (2014)",
    "santos": "Santos, Yuste, López de Haro, Odriozola & Ogarko, Phys. Rev. E 89, 040302(R) (2014)",
}
VALIDITY = {
    "farr_groot": "±0.01 vs 3D simulations of bi-/tridisperse (ratio ≤ 10) and log-normal mixtures",
    "desmond_weeks": f"fitted for δ ≤ {DW_DELTA_MAX:g}",
    "santos": "z = M2²/(M1·M3); tested on many simulated and experimental mixtures; input φ_mono is ours",
}


def desmond_weeks(delta: float, skewness: float) -> float:
    """Desmond & Weeks' (2014) phi_RCP = 0.634 + 0.0658 delta + 0.0857 S delta^2."""
    return DW_PHI0 + DW_C1 * delta + DW_C2 * skewness * delta * delta


def santos(z: float, phi_mono: float) -> float:
    """Santos et al.'s (2014) phi_J = phi_mono / (phi_mono + (1 - phi_mono) z), z = M2^2/(M1 M3)."""
    if not (0 < z <= 1 + 1e-12 and 0 < phi_mono < 1):
        raise ValueError(f"need 0 < z <= 1 and 0 < phi_mono < 1, got z={z!r}, phi_mono={phi_mono!r}")
    return phi_mono / (phi_mono + (1.0 - phi_mono) * z)


@dataclass(frozen=True)
class Prediction:
    """One model's phi_RCP for one distribution; ``in_range`` is False outside the authors' stated range."""

    model: str
    phi: float
    in_range: bool
    note: str

    @property
    def citation(self) -> str:
        return CITATIONS[self.model]


def predictions(distribution, phi_mono: float | None = None) -> list[Prediction]:
    """The three models for a distribution (spec or object). ``phi_mono``: Santos' input, our measured
    monodisperse phi_RCP (default: the paper's 0.6405)."""
    from ..core.size_distribution import parse
    from .farr_groot import phi_rcp_distribution

    dist = parse(distribution)
    desc = dist.descriptors()
    mono = PHI_RCP_MONO_PAPER if phi_mono is None else float(phi_mono)
    ratio = desc.size_ratio
    fg_ok = math.isfinite(ratio) and ratio <= 10 or dist.family in ("lognormal", "gaussian")
    return [
        Prediction("farr_groot", phi_rcp_distribution(dist), fg_ok, VALIDITY["farr_groot"]),
        Prediction("desmond_weeks", desmond_weeks(desc.delta, desc.skewness), desc.delta <= DW_DELTA_MAX,
                   VALIDITY["desmond_weeks"]),
        Prediction("santos", santos(desc.z, mono), True,
                   f"{VALIDITY['santos']} (φ_mono = {mono:.4f}{'' if phi_mono is not None else ', the paper'})"),
    ]
