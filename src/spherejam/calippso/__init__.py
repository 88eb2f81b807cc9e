"""CALiPPSO: jamming by a chain of linear programs, and the certificate it gives (docs/calippso.md)."""

from .run import CalippsoResult, run_calippso

__all__ = ["CalippsoResult", "run_calippso"]
