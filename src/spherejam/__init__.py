"""spherejam: jammed hard-sphere packings and random-close-packing limits.

Reproduces Baranau & Tallarek, "Random-close packing limits for monodisperse and polydisperse hard spheres",
Soft Matter 10, 3826 (2014), and certifies jamming with CALiPPSO (Artiaco et al., Phys. Rev. E 106, 055310 (2022)).

The layout follows the pipeline (docs/layout.md): ``core`` (the packing, its files, the cell list), ``engines``
(LS, MLS, FB), ``calippso``, ``analysis``, ``workflow``, ``formats`` and ``cli``. The functions a script needs are
importable from here: ``from spherejam import poisson_packing, run_ls, find_closest_jamming``, and the one call
that composes them, ``spherejam.jam(n=1000, psd="lognormal:sigma=0.3")`` (docs/python.md).
"""

from .core.errors import InputError, OverlapError, PackingFileError, SimulationError, SpherejamError
from .core.provenance import spherejam_version

__version__ = spherejam_version()

#: name -> module of the public functions and classes, imported on first use: the engines pull in numba, and
#: `import spherejam` (and Snakemake's DAG) stays light.
_API = {
    "Packing": "core.packing",
    "poisson_packing": "core.seeding",
    "read_packing": "core.packing_io",
    "write_packing": "core.packing_io",
    "run_ls": "engines.lubachevsky_stillinger",
    "find_closest_jamming": "engines.closest_jamming",
    "run_fb": "engines.force_biased",
    "RunResult": "engines.result",
    "run_calippso": "calippso.run",
    "CalippsoResult": "calippso.run",
    "jam": "jamming",
    "JamResult": "jamming",
}

__all__ = [
    "CalippsoResult", "InputError", "JamResult", "OverlapError", "Packing", "PackingFileError", "RunResult",
    "SimulationError", "SpherejamError", "__version__", "find_closest_jamming", "jam", "poisson_packing",
    "read_packing", "run_calippso", "run_fb", "run_ls", "write_packing",
]


def __getattr__(name):
    if name in _API:
        import importlib

        return getattr(importlib.import_module(f"{__name__}.{_API[name]}"), name)
    raise AttributeError(f"module 'spherejam' has no attribute {name!r}")
