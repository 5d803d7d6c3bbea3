"""Edge detection with the chapter's Green's-function differentiator D(x) (chapter §2).

``canny`` (gradient, non-maximum suppression on the backend, hysteresis), ``criteria``
(Canny's criteria of D(x) in closed form: the chapter's (ΣΛ)·SRC index) and ``kernels`` (the
fused non-maximum-suppression kernel).
"""

from .canny import DEFAULT_HIGH, DEFAULT_LOW, canny, hysteresis

__all__ = ["canny", "hysteresis", "DEFAULT_LOW", "DEFAULT_HIGH"]
