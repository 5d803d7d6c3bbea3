"""The version of gfgpu (read by the build from here: one place)."""

__version__ = "0.1.0"
