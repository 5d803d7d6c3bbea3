"""The README's API tour runs verbatim, from the repository root and from elsewhere."""

import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _tour():
    path = os.path.join(ROOT, "README.md")
    if not os.path.exists(path):
        pytest.skip("not running from a source checkout")
    text = open(path, encoding="utf-8").read()
    section = text.split("\n## API tour", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert len(blocks) == 1, "the API tour is one python block"
    return blocks[0]


@pytest.mark.parametrize("where", ["root", "elsewhere"])
def test_api_tour_runs_verbatim(where, tmp_path):
    cwd = ROOT if where == "root" else str(tmp_path)
    env = dict(os.environ, MPLBACKEND="Agg")
    env.pop("PYTHONPATH", None)
    res = subprocess.run([sys.executable, "-c", _tour()], cwd=cwd, env=env, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "Traceback" not in res.stderr


def test_dask_example_runs_with_the_installed_packages(tmp_path):
    """The README's Dask example needs nothing gfgpu does not install (zarr is not installed), and
    its result is the whole image's gradient."""
    text = open(os.path.join(ROOT, "README.md"), encoding="utf-8").read()
    section = text.split("\n## Large images, batches and Dask", 1)[1].split("\n## ", 1)[0]
    (block,) = [b for b in re.findall(r"```python\n(.*?)```", section, flags=re.S) if "gfgpu.dask" in b]
    import numpy as np
    scan = np.random.default_rng(3).random((700, 600)).astype(np.float32)
    np.save(tmp_path / "scan.npy", scan)
    check = ("\nimport gfgpu\nref = gfgpu.gradient(np.load('scan.npy'), 1.0, backend='numpy')[1]\n"
             "got = da.from_npy_stack('gx').compute()\n"
             "assert np.linalg.norm(got - ref) <= 1e-5 * np.linalg.norm(ref), np.linalg.norm(got - ref)\n")
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    res = subprocess.run([sys.executable, "-c", block + check], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
