"""The stereo kernels' constants (NO_MATCH, OUT_OF_VIEW, COST_MAX, the path sentinels) come from
gfgpu.stereo.spec, passed as -D defines (OpenCL) and wp.constant (Warp), never retyped."""
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _code_lines(path, comment):
    """The lines of the repository file ``path`` without their comments (``comment`` = "//" or "#")."""
    return [line.split(comment)[0] for line in (ROOT / path).read_text(encoding="utf-8").splitlines()]


def test_stereo_device_code_retypes_no_constant_of_the_spec():
    """NO_MATCH, the undefined path value, int32's largest cost, OUT_OF_VIEW and the byte mark are
    defined by gfgpu.stereo.spec (and the int16 path value by the launcher), not in the kernels."""
    literals = re.compile(r"2147483647|2147483648|16777216|16384|\(short16\)\(-1\)|wp\.int16\(-1\)|\b255\b")
    for path, comment in (("gfgpu/stereo/stereo.cl", "//"), ("gfgpu/stereo/_warp.py", "#")):
        bad = [line.strip() for line in _code_lines(path, comment) if literals.search(line)]
        assert not bad, f"{path} retypes constants of the specification: {bad}"
    cl = (ROOT / "gfgpu/stereo/stereo.cl").read_text(encoding="utf-8")
    for name in ("NO_MATCH", "OUT_OF_VIEW", "COST_MAX", "PAD_COST"):
        assert not re.search(rf"#define\s+{name}\b", cl), f"stereo.cl defines {name} itself"


def test_the_int16_path_value_of_the_opencl_sweeps_fits_its_bounds():
    pytest.importorskip("pyopencl")
    from gfgpu.stereo import _opencl
    from gfgpu.stereo import spec as specs
    # above every path value in view (a cost plus at most P2); plus a penalty, still an int16
    assert specs.COST_MAX + _opencl._PENALTY_MAX < _opencl._PATH_PAD
    assert _opencl._PATH_PAD + _opencl._PENALTY_MAX <= np.iinfo(np.int16).max
    assert specs.COST_MAX + _opencl._PENALTY_MAX < specs.PATH_UNDEFINED < specs.NO_CANDIDATE
    assert (specs.OUT_OF_VIEW & 0xFF) > specs.COST_MAX          # the byte volume's out-of-view mark


def test_opencl_stereo_kernels_take_no_match_from_the_spec(require_backend, monkeypatch):
    """Built with another NO_MATCH, the left-right check treats that value as "no match": the
    kernel's NO_MATCH is the specification's, passed as a define."""
    be = require_backend("opencl")
    from gfgpu.stereo import kernels
    from gfgpu.stereo import spec as specs
    disp = np.full((2, 9), 2.0, np.float32)
    right = np.full((2, 9), 2, np.int32)                 # every right winner agrees: d = 2 (steps = 1)
    margin = np.ones((2, 9), np.float32)

    def check():
        dev = [be.asarray(a.copy()) for a in (disp, right, margin)]
        kernels.left_right(be, *dev, 1, 1.0)
        ref_disp, ref_margin = specs.left_right_reference(disp, right, margin, 1, 1.0)
        np.testing.assert_array_equal(be.to_host(dev[0]), ref_disp)
        np.testing.assert_array_equal(be.to_host(dev[2]), ref_margin)
        return ref_disp

    assert np.isfinite(check()[:, 2:]).all()             # x - 2 inside the row: kept
    monkeypatch.setattr(specs, "NO_MATCH", 2)
    assert np.isnan(check()).all()                       # the same winners, now "no match"
