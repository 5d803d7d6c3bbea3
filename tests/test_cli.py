"""The ``gfgpu`` command as a user meets it: version, ``python -m gfgpu``, the backend line,
one-line errors, the devices table, and no stray Warp warning."""

import os
import subprocess
import sys

import numpy as np
import pytest

import gfgpu
from gfgpu.cli import main


def run(*argv, env=None):
    return subprocess.run([sys.executable, "-m", "gfgpu", *map(str, argv)], capture_output=True, text=True,
                          env=env, timeout=300)


def test_version_and_python_dash_m():
    res = run("--version")
    assert res.returncode == 0 and res.stdout.strip() == f"gfgpu {gfgpu.__version__}"
    assert gfgpu.__version__.count(".") == 2


@pytest.mark.parametrize("backend", ["numpy", "opencl", "warp"])
def test_every_command_says_which_backend_ran(tmp_path, capsys, require_backend, backend):
    be = require_backend(backend)
    out = tmp_path / "g.png"
    code = main(["gradient", "--example", "camera", "-o", str(out), "--backend", backend])
    text = capsys.readouterr()
    assert code == 0, text.err
    assert f"on {be.device}" in text.out
    first = text.out.splitlines()[0]
    assert first.startswith(f"gfgpu gradient: backend {backend} on ")
    assert main(["gradient", "--example", "camera", "-o", str(out), "--backend", backend, "--quiet"]) == 0
    assert "backend" not in capsys.readouterr().out


def test_errors_are_one_line_without_traceback(tmp_path):
    cases = [
        ("shift", tmp_path / "missing.png", "-o", tmp_path / "o.png", "--dx", 1),
        ("gradient", "--example", "camera", "-o", tmp_path / "o.png", "-u", -1, "--backend", "numpy"),
        ("blur", "--example", "camera", "-o", tmp_path / "o.png", "--zoom", 5, "--backend", "numpy"),
        ("gradient", "--example", "camera", "-o", tmp_path / "o.png", "--device", "cuda:0"),
    ]
    for argv in cases:
        res = run(*argv)
        assert res.returncode == 2, (argv, res.stderr)
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith(f"gfgpu {argv[0]}: "), (argv, res.stderr)
        assert "Traceback" not in res.stderr


def test_refuses_to_overwrite_its_input(tmp_path):
    import imageio.v3 as iio
    src = tmp_path / "in.png"
    iio.imwrite(src, np.zeros((8, 8), np.uint8))
    before = src.read_bytes()
    res = run("shift", src, "-o", src, "--dx", 1, "--backend", "numpy")
    assert res.returncode == 2 and "refusing to overwrite" in res.stderr
    assert src.read_bytes() == before


def test_devices_table_columns_align():
    res = run("devices")
    assert res.returncode == 0
    rows = res.stdout.splitlines()
    assert rows[0].split()[:4] == ["backend", "device", "kind", "state"]
    starts = {rows[0].index(h) for h in ("device", "kind", "state")}
    for row in rows[1:]:
        # every column starts where its header does
        assert all(row[i - 2:i] == "  " and row[i] != " " for i in starts), row


def test_no_warp_warning_unless_warp_runs():
    """Automatic resolution decides without initialising Warp where no CUDA driver exists."""
    from gfgpu.backends.warp import cuda_driver_present
    if cuda_driver_present():
        pytest.skip("a CUDA driver is present: Warp is the automatic choice here")
    code = ("import numpy as np, gfgpu, sys; gfgpu.shift(np.ones((8, 8), np.float32), (0, 1.5)); "
            "print('warp' in sys.modules)")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=dict(os.environ, GFGPU_BACKEND=""))
    assert "CUDA" not in res.stderr
    code = "import numpy as np, gfgpu; gfgpu.shift(np.ones((8, 8), np.float32), (0, 1.5), backend='warp')"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if res.returncode == 0:
        assert "Could not find or load the NVIDIA CUDA driver" not in res.stderr


@pytest.fixture
def small_png(tmp_path):
    import imageio.v3 as iio
    rng = np.random.default_rng(3)
    path = tmp_path / "small.png"
    iio.imwrite(path, (rng.random((40, 48)) * 255).astype(np.uint8))
    return path


@pytest.mark.parametrize("argv", [
    ("shift", "{img}", "-o", "{out}.png", "--dx", 1.5),
    ("blur", "{img}", "-o", "{out}.png", "--dx", 6, "--dy", -2),
    ("frames", "{img}", "-o", "{out}", "--dy", 4, "-n", 3),
    ("disparity", "{img}", "{img}", "-o", "{out}.png", "--max-disparity", 4),
    ("depth", "{img}", "-o", "{out}.png", "--light", 1, 0, 1),
    ("batch", "gradient", "{img}", "-o", "{out}"),
])
def test_each_command_names_its_backend(argv, small_png, tmp_path, capsys):
    args = [str(a).format(img=small_png, out=tmp_path / "result") for a in argv]
    assert main([*args, "--backend", "numpy"]) == 0, capsys.readouterr().err
    name = argv[0] if argv[0] != "batch" else "batch"
    assert f"gfgpu {name}: backend numpy on host" in capsys.readouterr().out
