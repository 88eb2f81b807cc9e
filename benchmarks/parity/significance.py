"""Tests over the pairs: phi_J and cost of ours against the C++ code, capped searches counted as censored values,
and late-stage unjamming. Too few pairs print "not estimable (n = ...)"."""

from __future__ import annotations

import math

import numpy as np

from .stages import phi_end, stage_list

#: Fewer complete pairs than this: tests and spreads are printed as "not estimable".
MIN_PAIRS_FOR_TEST = 5


def tests(ours: list[float], cpp: list[float]) -> str:
    """Paired Wilcoxon signed-rank test and Mann–Whitney U on phi_J of the complete pairs."""
    n = len(ours)
    if n < MIN_PAIRS_FOR_TEST:
        return f"not estimable (n = {n} complete pairs; a test needs >= {MIN_PAIRS_FOR_TEST})"
    from scipy import stats

    w = stats.wilcoxon(ours, cpp)
    u = stats.mannwhitneyu(ours, cpp, alternative="two-sided")
    d = np.asarray(ours) - np.asarray(cpp)
    return (f"paired diff ours - C++ = {d.mean():+.4f} ± {d.std(ddof=1) / math.sqrt(n):.4f} (s.e.); "
            f"Wilcoxon signed-rank p = {w.pvalue:.3g}; Mann–Whitney U = {u.statistic:.0f}, p = {u.pvalue:.3g} "
            f"(n = {n})")


#: The paired phi_J difference whose detection the study is sized for (issue 50).
TARGET_DIFFERENCE = 1e-3
#: Two-sided level of the interval and the tests, and the power at which a difference counts as "detectable".
ALPHA, POWER = 0.05, 0.8


def paired_t_power(n: int, sd: float, delta: float, alpha: float = ALPHA) -> float:
    """Power of the two-sided paired t-test at level ``alpha`` to detect a true mean difference ``delta`` among ``n``
    pairs whose differences have standard deviation ``sd`` (noncentral t with n - 1 degrees of freedom)."""
    from scipy import stats

    df, ncp = n - 1, abs(delta) * math.sqrt(n) / sd
    crit = stats.t.ppf(1.0 - alpha / 2.0, df)
    # the lower tail P(T < -crit) is written as P(T > crit) at -ncp: scipy's nct.cdf returns NaN there at ncp ~ 9
    upper, lower = float(stats.nct.sf(crit, df, ncp)), float(stats.nct.sf(crit, df, -ncp))
    if not math.isfinite(upper):
        upper = 1.0 - float(stats.nct.cdf(crit, df, ncp))
    return upper + (lower if math.isfinite(lower) else 0.0)


def detectable_difference(n: int, sd: float, power: float = POWER, alpha: float = ALPHA) -> float:
    """The smallest true difference the paired t-test detects with ``power`` at this ``n`` and ``sd``."""
    from scipy import optimize

    hi = sd
    while paired_t_power(n, sd, hi, alpha) < power:
        hi *= 2.0
    return float(optimize.brentq(lambda d: paired_t_power(n, sd, d, alpha) - power, 0.0, hi, xtol=1e-12 * sd))


def paired_difference(ours: list[float], cpp: list[float], delta: float = TARGET_DIFFERENCE) -> str:
    """phi_J, ours - C++, over complete pairs: mean with its 95 % t-interval, the Wilcoxon signed-rank test, and the
    power of the paired t-test to detect ``delta`` (with the difference it detects at 80 % power). The power uses
    the observed spread of the differences; the signed-rank test has ~95 % of the t-test's efficiency for normal
    differences, so its power is slightly lower."""
    n = len(ours)
    if n < MIN_PAIRS_FOR_TEST:
        return f"not estimable (n = {n} complete pairs; needs >= {MIN_PAIRS_FOR_TEST})"
    from scipy import stats

    d = np.asarray(ours, dtype=float) - np.asarray(cpp, dtype=float)
    mean, sd = float(d.mean()), float(d.std(ddof=1))
    half = stats.t.ppf(1.0 - ALPHA / 2.0, n - 1) * sd / math.sqrt(n)
    if sd == 0.0:
        return (f"ours - C++ = {mean:+.5f}, all {n} differences equal; interval, test and power not estimable "
                f"(n = {n}, zero spread)")
    w = stats.wilcoxon(d)
    return (f"ours - C++ = {mean:+.5f}, 95 % CI [{mean - half:+.5f}, {mean + half:+.5f}] (sd {sd:.5f}); "
            f"Wilcoxon signed-rank p = {w.pvalue:.3g}; power to detect |diff| = {delta:g}: "
            f"{paired_t_power(n, sd, delta):.2f}; detectable at 80 % power: {detectable_difference(n, sd):.5f} "
            f"(paired t, alpha = {ALPHA:g}, n = {n})")


def _phi_end(r: dict) -> float | None:
    return r["phi_J"] if r["phi_J"] is not None else phi_end(r)


def censored_phi_sign_test(pairs: list[tuple[dict, dict]]) -> str:
    """Is our phi_J lower than the C++ one? A capped search's phi_J is at least its phi at the cap, so a pair is
    decided when both finished, or when the finished one lies below the other's phi at the cap."""
    lower = higher = undecided = 0
    for o, c in pairs:
        po, pc = _phi_end(o), _phi_end(c)
        if po is None or pc is None or (o["capped"] and c["capped"]):
            undecided += 1
        elif not (o["capped"] or c["capped"]):
            lower += po < pc
            higher += po >= pc
        elif c["capped"] and po < pc:
            lower += 1
        elif o["capped"] and pc < po:
            higher += 1
        else:
            undecided += 1
    n = lower + higher
    return _with_sign_test(f"ours lower in {lower}, higher in {higher} of {n} decided pairs ({undecided} undecided)",
                           lower, n)


def censored_sign_test(pairs: list[tuple[dict, dict]]) -> str:
    """Does our search need fewer collisions than the C++ one? Per pair, decided where possible: both finished, or
    one capped while the other finished below that cap. A sign test on the decided pairs."""
    fewer = more = undecided = 0
    for o, c in pairs:
        if o["capped"] and c["capped"]:
            undecided += 1
        elif c["capped"] and o["collisions"] < c["collisions"]:
            fewer += 1
        elif o["capped"] and c["collisions"] < o["collisions"]:
            more += 1
        elif not (o["capped"] or c["capped"]):
            fewer += o["collisions"] < c["collisions"]
            more += o["collisions"] >= c["collisions"]
        else:
            undecided += 1
    n = fewer + more
    return _with_sign_test(f"ours needed fewer collisions in {fewer} of {n} decided pairs ({undecided} undecided)",
                           fewer, n)


def _with_sign_test(text: str, successes: int, n: int) -> str:
    """``text`` and the two-sided sign test of ``successes`` of ``n`` decided pairs."""
    if n < MIN_PAIRS_FOR_TEST:
        return text + f"; sign test not estimable (n = {n})"
    from scipy import stats

    return text + f"; sign test p = {stats.binomtest(successes, n).pvalue:.3g}"


def fisher_line(rows: dict[str, list]) -> str:
    """Fisher's exact test: do late stages unjam (p_min < 1e6) as often in both codes?"""
    counts = {}
    for code in ("ours", "cpp"):
        late = [u for _, r in rows[code] if stage_list(r) for _, u in r["stage"]["late"]]
        counts[code] = (sum(late), len(late) - sum(late))
    (a, b), (c, d) = counts["ours"], counts["cpp"]
    text = f"{a} of {a + b} against {c} of {c + d}"
    if min(a + b, c + d) < MIN_PAIRS_FOR_TEST:
        return text + f"; not estimable (n = {a + b}, {c + d} stages)"
    from scipy import stats

    return text + f"; Fisher exact p = {stats.fisher_exact([[a, b], [c, d]]).pvalue:.3g}"
