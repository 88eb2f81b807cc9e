"""spherejam: jammed hard-sphere packings and random-close-packing limits.

Reproduces Baranau & Tallarek, "Random-close packing limits for monodisperse and polydisperse hard spheres",
Soft Matter 10, 3826 (2014), and certifies jamming with CALiPPSO (Artiaco et al., Phys. Rev. E 106, 055310 (2022)).
"""

__version__ = "0.1.0"

from .errors import InputError, OverlapError, PackingFileError, SimulationError, SpherejamError  # noqa: E402

__all__ = [
    "InputError",
    "OverlapError",
    "Packing",
    "PackingFileError",
    "SimulationError",
    "SpherejamError",
    "__version__",
]


def __getattr__(name):
    # Packing pulls in numba; importing it lazily keeps `import spherejam` (and Snakemake's DAG) light.
    if name == "Packing":
        from .packing import Packing

        return Packing
    raise AttributeError(f"module 'spherejam' has no attribute {name!r}")
