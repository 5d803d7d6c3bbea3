"""The private core of gfgpu: what every operator shares, below the backends.

``validation`` (argument checks, dtype policy), ``boundary`` (the boundary modes: the index map
and the integer codes kernels take), ``bspline`` (the cubic B-spline: prefilter pole, tap weights,
edge continuation), ``passes`` and ``recursion`` (the one recursion primitive: what a pass
computes, its plan with the boundary mode as initial state, and its float64 numpy
specification), ``lines`` (axis and oblique line geometry), ``program`` and
``job`` (an operator as passes, and one call's input/output handling), ``carry`` (exact
recursion state across segments of a line) and ``strips`` (images larger than the working set).

Nothing here imports from the rest of gfgpu (``docs/architecture.md``); the layers above may
import any name from here, private or not.
"""
