"""The import paths of the flat layout of spherejam 0.1 (``spherejam.lubachevsky_stillinger`` and so on), kept
working: each old module name is an alias of its module in the sub-packages, with a DeprecationWarning."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old module (under ``spherejam.``) -> its module now
MOVED = {
    "atomic": "core.atomic", "checkpoint": "core.checkpoint", "errors": "core.errors", "neighbours": "core.neighbours",
    "output_paths": "core.output_paths", "packing": "core.packing", "packing_io": "core.packing_io",
    "progress": "core.progress", "provenance": "core.provenance", "seeding": "core.seeding",
    "validation": "core.validation",
    "runs": "engines.driver", "lubachevsky_stillinger": "engines.lubachevsky_stillinger",
    "closest_jamming": "engines.closest_jamming", "force_biased": "engines.force_biased",
    "event_driven": "engines.kernels.event_driven",
    "lp_constraints": "calippso.constraints",
    "contacts": "analysis.contacts", "structure": "analysis.structure", "farr_groot": "analysis.farr_groot",
    "experiment": "workflow.experiment", "dataset": "workflow.dataset", "fits": "workflow.fits",
    "bands": "workflow.bands", "tables": "workflow.tables", "figures": "workflow.figures",
    "cluster_resources": "workflow.cost_model", "paper_reference": "workflow.paper_reference",
    "packing_record": "workflow.packing_record", "render": "workflow.render",
}

_PREFIX = "spherejam."


class _AliasFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, fullname, path=None, target=None):
        if fullname.startswith(_PREFIX) and fullname[len(_PREFIX):] in MOVED:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        return None

    def exec_module(self, module):
        new = _PREFIX + MOVED[module.__name__[len(_PREFIX):]]
        warnings.warn(f"{module.__name__} is now {new}", DeprecationWarning, stacklevel=2)
        # the import system hands out whatever sys.modules holds under the name once this returns
        sys.modules[module.__name__] = importlib.import_module(new)


FINDER = _AliasFinder()
