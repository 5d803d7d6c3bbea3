"""A non-finite input is refused with one error and no numpy RuntimeWarning before it.

The numpy backend's blocked products ran on the NaN or infinity before the finite check read
their result, and numpy printed "invalid value encountered in matmul" ahead of the error.
"""

import warnings

import numpy as np
import pytest

import gfgpu

CALLS = {
    "green_filter rows": lambda x, be: gfgpu.green_filter(x, gfgpu.UniformGreen(3.0), axis=1, backend=be),
    "green_filter columns": lambda x, be: gfgpu.green_filter(x, gfgpu.UniformGreen(3.0), axis=0, backend=be),
    "green_filter oblique": lambda x, be: gfgpu.green_filter(x, gfgpu.UniformGreen(3.0), angle=0.3, backend=be),
    "shift": lambda x, be: gfgpu.shift(x, (0.5, -1.5), backend=be),
    "derivative": lambda x, be: gfgpu.derivative(x, 1.0, axis=1, backend=be),
    "gradient": lambda x, be: gfgpu.gradient(x, 1.0, backend=be),
    "motion_blur": lambda x, be: gfgpu.motion_blur(x, (2.0, 3.0), backend=be),
    "canny": lambda x, be: gfgpu.canny(x, 1.0, backend=be),
}


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("call", list(CALLS))
def test_refused_without_warnings(backend, call, dtype, bad):
    if dtype == np.float64 and not backend.supports_float64:
        pytest.skip("no float64 on this device")
    x = np.ones((300, 260), dtype)       # long enough for the numpy backend's blocked products
    x[150, 100] = bad
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(ValueError, match="NaN or infinite"):
            CALLS[call](x, backend)
