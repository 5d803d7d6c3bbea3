"""Edge detection with the chapter's Green's-function differentiator D(x) (chapter §2).

``canny`` (gradient, non-maximum suppression on the backend, hysteresis), ``operator`` (its
one-signed differentiator, whose step response has one extremum), ``criteria``
(Canny's criteria of D(x) in closed form: the chapter's (ΣΛ)·SRC index) and ``kernels`` (the
fused non-maximum-suppression kernel).
"""

from .canny import DEFAULT_HIGH, DEFAULT_LOW, canny, check_arguments, edge_gradient, hysteresis

__all__ = ["canny", "edge_gradient", "check_arguments", "hysteresis", "DEFAULT_LOW", "DEFAULT_HIGH"]
