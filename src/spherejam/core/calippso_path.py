"""Which path CALiPPSO's LPs take at N when the user does not choose: the one rule that the driver
(:func:`spherejam.calippso.run.run_calippso`) and the workflow's cost model share.

It lives in core, with no imports, so that the cost model (which Snakemake evaluates for every job) can ask it
without loading numpy or HiGHS.
"""

from __future__ import annotations

#: Smallest N whose LPs above sqrt(Gamma) - 1 = 1e-9 are, by default, intermediate steps from the interior point
#: (no vertex, no crossover); None: never by default, only when asked. The measurements point at 4096, where no LP
#: is warm-started any more and every LP is a cold HiPO solve whose vertex, when not certified, costs up to 500
#: pivots and a second HiPO solve with crossover, where an interior step costs one HiPO solve; below it
#: warm-started simplex and active-set vertices are 2-4 times cheaper than interior steps. It stays None until the
#: statistical comparison of the two paths over many packings and the whole N = 4096 runs are complete
#: (docs/calippso.md §10.11 has the figures so far and the commands that finish them).
INTERIOR_STEPS_MIN_N: int | None = None


def interior_steps_at(n: int, requested: bool | None = None) -> bool:
    """Whether a certification of ``n`` spheres takes interior steps: ``requested`` if given (the CLI's
    ``--interior-steps`` / ``--no-interior-steps``, the config's ``calippso.interior_steps``), else from
    :data:`INTERIOR_STEPS_MIN_N` spheres on (never while it is None)."""
    if requested is not None:
        return bool(requested)
    return INTERIOR_STEPS_MIN_N is not None and int(n) >= INTERIOR_STEPS_MIN_N
