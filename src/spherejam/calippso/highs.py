"""A HiGHS LP built from arrays: the one model builder of the CALiPPSO LP (:mod:`.lp`) and of the rattler-placement
LP of the active-set solve (:mod:`.active_set`)."""

from __future__ import annotations

import numpy as np


def highs_model(cost, col_lower, col_upper, row_lower, row_upper, start, index, value):
    """A HiGHS LP (minimise cost . x, row_lower <= A x <= row_upper, col bounds) with A given row-wise (CSR
    ``start``, ``index``, ``value``); infinite bounds become HiGHS's infinity."""
    import highspy

    inf = highspy.kHighsInf
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = len(cost), len(row_upper)
    lp.col_cost_ = np.asarray(cost, dtype=float)
    lp.col_lower_, lp.col_upper_ = np.clip(col_lower, -inf, inf), np.clip(col_upper, -inf, inf)
    lp.row_lower_, lp.row_upper_ = np.clip(row_lower, -inf, inf), np.clip(row_upper, -inf, inf)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = len(cost), len(row_upper)
    lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = start, index, value
    return lp
