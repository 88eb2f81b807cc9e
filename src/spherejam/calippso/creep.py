"""A certification that creeps, told to its user once (docs/calippso.md §8.1, §10.13).

Some inputs are far from their LP-jammed state although their gaps are tiny: each LP then finds a new contact network,
moves the packing along nearly floppy directions, and gains little (§8.1). Such runs still converge, but after tens
to hundreds of LPs, and the per-LP progress lines alone do not say why. The rule here only reads the history; it
changes nothing in the run.
"""

from __future__ import annotations

import numpy as np

#: LPs per window. A run creeps when each of its last ``CREEP_WINDOW`` LPs changed the contact network and the
#: smallest sqrt(Gamma) - 1 among them is not below a tenth of the smallest of the window before: no decade of
#: progress in ``CREEP_WINDOW`` LPs. On the LP records of docs/calippso.md §10.13 it marks every run of 36 LPs or
#: more at LP 20-25 and none of 18 LPs or fewer.
CREEP_WINDOW = 10


def creeping(sqrt_inflation_minus_1, contact_changes, window: int = CREEP_WINDOW) -> bool:
    """Whether the LPs so far creep: ``sqrt_inflation_minus_1`` and ``contact_changes`` (contacts gained plus lost,
    -1 where not known) per LP, oldest first."""
    g = np.asarray(sqrt_inflation_minus_1, dtype=float)
    changes = np.asarray(contact_changes)
    if g.size < 2 * window:
        return False
    return bool(np.all(changes[-window:] != 0) and np.min(g[-window:]) >= 0.1 * np.min(g[-2 * window:-window]))


def creep_message(lps: int, sqrt_inflation_minus_1: float, window: int = CREEP_WINDOW) -> str:
    """The one line a creeping run logs."""
    return (f"calippso: {lps} LPs, and sqrt(Gamma)-1 ({sqrt_inflation_minus_1:.1e}) has not fallen tenfold in the "
            f"last {window} while each LP changed the contacts: this input creeps towards its jammed state "
            "(docs/calippso.md §8.1). Such runs converge after tens to hundreds of LPs; inputs at their own pressure "
            "(MLS outputs at p = 1e12) certify in far fewer (§10.13)")
