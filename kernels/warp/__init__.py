"""Warp kernels at module scope, overloaded for float32 and float64."""
