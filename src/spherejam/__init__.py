"""spherejam: jammed hard-sphere packings and random-close-packing limits.

Reproduces Baranau & Tallarek, "Random-close packing limits for monodisperse and polydisperse hard spheres",
Soft Matter 10, 3826 (2014), and certifies jamming with CALiPPSO (Artiaco et al.).
"""

__version__ = "0.1.0"

from .errors import InputError, OverlapError, PackingFileError, SimulationError, SpherejamError  # noqa: E402
from .packing import Packing  # noqa: E402

__all__ = [
    "__version__",
    "Packing",
    "SpherejamError",
    "InputError",
    "PackingFileError",
    "OverlapError",
    "SimulationError",
]
