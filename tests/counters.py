"""Counters of what a call rebuilds or allocates, for the first-call tests (no timing)."""


def program_builds(be):
    """Programs built so far for ``be`` (OpenCL), or None where builds are not counted here."""
    if be.name != "opencl":
        return None
    from gfgpu.backends.opencl import launch
    return sum(1 for key in launch._programs if key[0] == be.context)


def fresh_pool_blocks(be):
    """New blocks the backend's host pool has allocated so far, or None where it keeps no pool."""
    pool = getattr(be, "_host_pool", None)
    return None if pool is None else pool.stats["fresh"]
