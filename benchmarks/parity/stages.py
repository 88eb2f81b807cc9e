"""A search's history cut into MLS stages (maximal runs of windows at one rate), and the figures of its stages."""

from __future__ import annotations

from .ours import P_MAX

#: A compression stage "unjams" when its lowest window pressure falls below this (issue 24).
UNJAM_PRESSURE = 1e6
#: "Late" compression stages (issue 24: gamma <= 3e-4 with gamma_0 = 1e-2, f = 2).
LATE_RATE = 3.2e-4


def stages(history: dict[str, list]) -> list[dict]:
    """Maximal runs of windows at one rate: rate, windows, lowest and last pressure, phi at the end."""
    out: list[dict] = []
    for g, p, phi in zip(history.get("rate", []), history.get("pressure", []), history.get("phi", [])):
        if out and out[-1]["rate"] == g:
            s = out[-1]
            s["windows"] += 1
            s["p_min"] = min(s["p_min"], p)
            s["p_end"], s["phi_end"] = p, phi
        else:
            out.append({"rate": g, "windows": 1, "p_min": p, "p_end": p, "phi_end": phi})
    return out


def stage_list(result: dict) -> list[dict]:
    """The stages of a search: cut from its per-window history, or as stored in a compact record (:func:`compact`)."""
    if (result.get("history") or {}).get("rate"):
        return stages(result["history"])
    return result.get("stages") or []


def phi_end(result: dict) -> float | None:
    """phi at the last window (for a capped search a lower bound of its phi_J)."""
    phi = (result.get("history") or {}).get("phi")
    return phi[-1] if phi else result.get("phi_end")


def compact(result: dict) -> dict:
    """A result without its per-window history, with its stages and last phi instead: what the summary needs, in a
    few kB (the records committed under benchmarks/records/parity/)."""
    out = {k: v for k, v in result.items() if k not in ("history", "stage")}
    out["stages"], out["phi_end"] = stage_list(result), phi_end(result)
    return out


def stage_figures(result: dict) -> dict:
    """Windows per compression stage (by rate), unjammed fraction of the re-compressions, stalls."""
    st = stage_list(result)
    if result.get("capped"):
        st = st[:-1]  # the stage the cap cut is unfinished
    comp = [s for s in st if s["rate"] > 0]
    later = comp[1:]  # every compression after the first starts from a (nearly) jammed state
    return {
        "compression_windows": [s["windows"] for s in comp],
        "compression_rates": [s["rate"] for s in comp],
        "equilibration_windows": [s["windows"] for s in st if s["rate"] == 0],
        "unjammed": sum(s["p_min"] < UNJAM_PRESSURE for s in later), "recompressions": len(later),
        "late": [(s["windows"], s["p_min"] < UNJAM_PRESSURE) for s in later if s["rate"] <= LATE_RATE],
        "stalled": sum(s["p_end"] < P_MAX for s in comp[:-1]),
    }
