"""The portable numpy backend (host, float64, vectorised over lines)."""

from .backend import NumpyBackend

__all__ = ["NumpyBackend"]
