"""What every number a user gives may be: one set of limits for the CLI arguments, the config schema and the manifest.

Each limit is a :class:`Bound` named after its config field (``mls.final_rate``). The CLI builds its argparse
types from them (:meth:`Bound.arg`), :func:`spherejam.workflow.config.check_config` applies them to an experiment
config together with the consistency rules a JSON schema cannot express, and ``config/schema.yaml`` carries the same
numbers (a test checks that they agree). Configs themselves belong to the workflow layer; this module holds only the
plain limits, so that every layer may use them. The limits are those of the engines (an FB rate must be < 1), those
that let a run end (a rate of 1e-300 never jams) and those of a machine (N spheres must fit in memory).

Every check raises :class:`~spherejam.core.errors.InputError` whose one-line message starts with the field path and
the offending element, e.g. ``ls.rates[1]=0.0: must be >= 1e-08``.
"""

from __future__ import annotations

import argparse
import math
import numbers
from dataclasses import dataclass
from typing import Any

from .errors import InputError
from .rate_ladder import last_rate_floor, stage_count

#: Largest N: 10^7 spheres take ~1 GB in the engines' arrays; the paper uses 10^4.
N_MAX = 10_000_000
#: Seeds are stored as signed 64-bit integers in the packing files.
SEED_MAX = 2**63 - 1
#: LS / MLS compression rates gamma = d rho/dt (units m = kB = 1, T = 0.2). Below the minimum a compression to
#: p_max takes more than ~10^4 times the paper's slowest run (1/gamma = 10^4); above the maximum the spheres grow
#: by their own size within a mean free time.
LS_RATE_MIN, LS_RATE_MAX = 1e-8, 1e3
#: FB contraction rate per iteration: the engine needs gamma < 1; below 1e-9 the paper's nominal-density rule
#: leaves (0, 1) (at 1e-19) long after the run has become endless (iterations ~ 1/gamma; the paper's slowest 1e-7).
FB_RATE_MIN, FB_RATE_MAX = 1e-9, 1.0
#: MLS rate divisor per stage: beyond 100 the last stage's rate final_rate/f falls far below final_rate.
DECREASE_FACTOR_MAX = 100.0
#: Reduced-pressure threshold: > 1, and reachable in double precision (gaps ~ 1/p, relative precision 1e-16).
P_MAX_MAX = 1e15
#: Most configurations a config may ask for (runs of one protocol, sigma, gamma and replica).
MAX_RUNS = 1_000_000


@dataclass(frozen=True)
class Bound:
    """A closed or open interval for a number; ``integer`` also requires a whole number."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False

    def rule(self) -> str:
        kind = "an integer" if self.integer else "a finite number"
        text = (lambda x: str(int(x))) if self.integer else (lambda x: f"{x:g}")
        parts = []
        if self.lo is not None:
            parts.append(f"{'>' if self.lo_open else '>='} {text(self.lo)}")
        if self.hi is not None:
            parts.append(f"{'<' if self.hi_open else '<='} {text(self.hi)}")
        return f"must be {kind}" + (f" {' and '.join(parts)}" if parts else "")

    def ok(self, value: Any) -> bool:
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            return False
        if self.integer and not isinstance(value, numbers.Integral):
            return False
        if not math.isfinite(value):
            return False
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        return not (self.hi is not None and (value >= self.hi if self.hi_open else value > self.hi))

    def check(self, field: str, value: Any):
        if not self.ok(value):
            raise InputError(f"{field}={value!r}: {self.rule()}")
        return value

    def arg(self, text: str):
        """Parse a command-line value (argparse ``type=``); integers also as ``1e6``."""
        try:
            value: Any = int(text) if self.integer else float(text)
        except ValueError:
            value = _whole(text) if self.integer else None
            if value is None:
                raise argparse.ArgumentTypeError(
                    f"{text!r} is not {'an integer' if self.integer else 'a number'}") from None
        if not self.ok(value):
            raise argparse.ArgumentTypeError(f"{text!r}: {self.rule()}")
        return value


def _whole(text: str) -> int | None:
    try:
        x = float(text)
    except ValueError:
        return None
    return int(x) if math.isfinite(x) and x == int(x) else None


LS_RATE = Bound(LS_RATE_MIN, LS_RATE_MAX)
FB_RATE = Bound(FB_RATE_MIN, FB_RATE_MAX, hi_open=True)
P_MAX = Bound(1.0, P_MAX_MAX, lo_open=True)
SIGMA = Bound(0.0, 1.0)
UNIT_OPEN = Bound(0.0, 1.0, lo_open=True, hi_open=True)
SECONDS = Bound(0.0, None, lo_open=True)  # wall-time limits: > 0 (0 would stop before the first step)
#: Threads of one job (HiGHS and HiPO's BLAS in a CALiPPSO certification).
THREADS = Bound(1, 256, integer=True)
INTERVAL = Bound(0.0, None)  # checkpoint and progress intervals: >= 0 seconds, 0 = at every window or iteration

#: Limits by config field (also the names of the matching CLI options' values).
FIELDS: dict[str, Bound] = {
    "n": Bound(2, N_MAX, integer=True),
    "seed": Bound(0, SEED_MAX, integer=True),
    "phi_nominal": UNIT_OPEN,
    "sigmas[]": SIGMA,
    "replicas": Bound(1, 10_000, integer=True),
    "rates.count": Bound(1, 100_000, integer=True),
    "ls.rates[]": LS_RATE,
    "ls.p_max": P_MAX,
    "fb.rates[]": FB_RATE,
    "fb.phi_nominal": UNIT_OPEN,
    "mls.initial_rate": LS_RATE,
    "mls.decrease_factor": Bound(1.0, DECREASE_FACTOR_MAX, lo_open=True),
    "mls.final_rate": LS_RATE,
    "mls.p_max": P_MAX,
    "mls.max_equilibration_windows": Bound(1, 1_000_000, integer=True),
    "mls.stall_windows": Bound(1, 100_000_000, integer=True),
    "mls.max_collisions_per_particle": Bound(0.0, 1e12, lo_open=True),
    "mls.max_wall_time": SECONDS,
    "validation_grid.sigmas[]": SIGMA,
    "validation_grid.ls_rates[]": LS_RATE,
    "validation_grid.replicas": Bound(1, 10_000, integer=True),
    "validation_grid.decrease_factors[]": Bound(1.0, DECREASE_FACTOR_MAX, lo_open=True),
    "validation_grid.initial_rates[]": LS_RATE,
    "validation_grid.final_rates[]": LS_RATE,
    "fits.confidence": UNIT_OPEN,
    "fast.ls_max_inverse_rate": Bound(0.0, None, lo_open=True),
    "fast.fb_max_inverse_rate": Bound(0.0, None, lo_open=True),
    "gcp_monodisperse": UNIT_OPEN,
    "calippso.threads": THREADS,
    "calippso.per_cell": Bound(1, 1_000_000, integer=True),
}

#: Limits of CLI-only values.
EVENTS_PER_PARTICLE = Bound(1, 1_000_000, integer=True)
MAX_COLLISIONS = Bound(1, 10**15, integer=True)
PORE_SAMPLES = Bound(1, 1_000_000_000, integer=True)
CALIPPSO_ITERATIONS = Bound(1, 1_000_000, integer=True)
FB_ITERATIONS = Bound(0, 10**12, integer=True)
OVERLAP_TOLERANCE = Bound(0.0, 1.0)
IMAGE_SIZE = Bound(16, 8192, integer=True)
#: The side L of a packing's box, in any length unit, for every reader, writer and ``import --box``: L**d (d <= 5)
#: and N ball volumes stay finite, normal doubles, so phi and the cell list cannot overflow.
BOX_MIN, BOX_MAX = 1e-50, 1e50
BOX_SIDE = Bound(BOX_MIN, BOX_MAX)
#: The HiGHS solvers CALiPPSO's LPs can be sent to (here, not in calippso.py, so that the CLI need not load numba).
LP_SOLVERS = ("hipo", "ipx", "simplex")
#: The most rates an MLS ladder may have. The paper's has 18 (gamma_0 = 10, f = 2, gamma_f = 1e-4); a factor just
#: above 1 would make ~1e8, which the engine and the cost model would walk one by one.
MLS_MAX_STAGES = 10_000


def check_mls(initial_rate: float, decrease_factor: float, final_rate: float,
              names: tuple[str, str, str] = ("mls.initial_rate", "mls.decrease_factor", "mls.final_rate")) -> None:
    """MLS consistency: final rate <= initial rate, the last stage's rate (>= final_rate/f) still ends, and the
    ladder has at most MLS_MAX_STAGES rates.

    ``names`` are how the three values are called where they came from (config fields or CLI options)."""
    g0, f, gf = names
    if final_rate > initial_rate:
        raise InputError(f"{gf}={final_rate!r}: must be <= {g0} ({initial_rate!r})")
    floor = last_rate_floor(decrease_factor, final_rate)
    if floor < LS_RATE_MIN:
        raise InputError(f"{f}={decrease_factor!r}: with {gf} {final_rate!r} the last stage may run at gamma = "
                         f"{floor:.3g} < {LS_RATE_MIN:g}, which never jams")
    stages = stage_count(initial_rate, decrease_factor, final_rate)
    if stages > MLS_MAX_STAGES:
        raise InputError(f"{f}={decrease_factor!r}: from {g0} {initial_rate!r} to {gf} {final_rate!r} the ladder "
                         f"has {stages} rates (at most {MLS_MAX_STAGES}); use a larger factor")
