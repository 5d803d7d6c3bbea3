"""The backends (gfgpu.backends): every backend against the numpy specification of what it runs."""
