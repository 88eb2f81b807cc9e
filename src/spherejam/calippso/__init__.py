"""CALiPPSO: jamming by a chain of linear programs, and the certificate it gives (docs/calippso.md).

``run`` is the driver; ``schedule`` the cutoff and bound of each iteration; ``constraints`` the LP's rows; ``lp``
one LP solved by HiGHS (solver choice, warm starts, certified vertex); ``active_set`` the vertex predicted and
certified without HiGHS; ``solution`` what a solve returns; ``network`` contacts, rattlers and forces from the duals;
``lp_log`` the per-LP CSV record of a run.
The force and gap distributions of a certified packing are analysis: :mod:`spherejam.analysis.distributions`.
"""

from .run import CalippsoResult, run_calippso

__all__ = ["CalippsoResult", "run_calippso"]
