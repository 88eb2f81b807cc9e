"""The package's one matplotlib set-up: the non-interactive Agg backend, imported only when a figure is drawn (so
that ``import spherejam`` and Snakemake's DAG stay light)."""

from __future__ import annotations


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
