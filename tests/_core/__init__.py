"""The engine's core (gfgpu._core): recursions, lines, oblique passes."""
