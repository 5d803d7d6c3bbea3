"""One table of motion kinds (``gfgpu.motion.kinds``): every entry point offers every kind and every
PSF of it, and agrees with ``gfgpu.motion_blur`` called directly.

The entry points: ``gfgpu.synthesize_motion``, ``gfgpu.dask.motion_blur`` (chunked and not),
``gfgpu.batch`` (``process_file`` and ``gfgpu batch blur``), and the ``gfgpu blur`` / ``gfgpu
frames`` commands.  Expected frame velocities and Dask chunk layouts are written out here, not
read from the table, so a drifting table fails.
"""

import argparse

import dask.array as da
import imageio.v3 as iio
import numpy as np
import pytest
import tifffile
from scipy.ndimage import gaussian_filter

import gfgpu.dask as gd
from gfgpu import batch, io
from gfgpu.cli import build_parser, main
from gfgpu.cli.motion_args import MOTION_OPTIONS, psf_help
from gfgpu.motion import motion_blur, synthesize_motion
from gfgpu.motion.kinds import KINDS, MOTIONS, PSFS, PointSpread, motion_kind
from gfgpu.motion.spec import PSF_CODES

from .common import float_dtype

H, W = 24, 30


def _image(shape=(H, W), seed=0):
    return gaussian_filter(np.random.default_rng(seed).random(shape), 1.5)


def _field(seed=1):
    return np.random.default_rng(seed).uniform(-2.5, 2.5, (2, H, W))


#: every entry of the table: (kind=, velocity, center); uniform motion oblique and along each axis
CASES = {
    "uniform-oblique": ("uniform", (1.5, -2.25), None),
    "uniform-rows": ("uniform", (0.0, 3.5), None),
    "uniform-cols": ("uniform", (-2.5, 0.0), None),
    "field": ("uniform", _field(), None),
    "zoom-in": ("zoom", 0.3, (11.0, 14.0)),
    "zoom-out-two-rates": ("zoom", (-0.15, 0.25), None),
    "rotation": ("rotation", 25.0, (10.0, 16.0)),
}


def _velocity_at(kind, velocity, t):
    """The motion at the fraction ``t``, written out (not the table's ``at``)."""
    if kind == "zoom":
        u1y, u1x = np.broadcast_to(np.asarray(velocity, float), (2,))
        return ((1 + u1y) ** t - 1, (1 + u1x) ** t - 1)
    if kind == "rotation":
        return velocity * t
    if np.ndim(velocity) == 3:
        return velocity * t
    return (velocity[0] * t, velocity[1] * t)


def _expected_chunks(case, psf, chunks):
    """The chunks of the Dask result: kept (G_u along an axis, carried), one axis whole (the box along
    an axis), or the whole plane (oblique, field, zoom, rotation)."""
    lead, rows, cols = chunks
    if case in ("uniform-rows", "uniform-cols") and psf == "green":
        return chunks
    if case == "uniform-rows" and psf == "box":
        return (lead, rows, (W,))
    if case == "uniform-cols" and psf == "box":
        return (lead, (H,), cols)
    return (lead, (H,), (W,))


def _close(a, b, tol=1e-10):
    np.testing.assert_allclose(a, b, rtol=0, atol=tol * max(1.0, float(np.abs(b).max())))


# --------------------------------------------------------------------------------------
# the table
# --------------------------------------------------------------------------------------
def test_the_table_covers_every_kind_and_psf():
    assert KINDS == ("uniform", "zoom", "rotation")
    assert tuple(PSFS) == ("green", "box")
    assert {name for name, _ in PSF_CODES} == set(PSFS)
    for name, psf in PSFS.items():
        assert psf.name == name and psf.code(True) == PSF_CODES[name, True] \
            and psf.code(False) == PSF_CODES[name, False]
    # the cases reach every entry, and a (2, H, W) velocity selects the field
    assert {motion_kind(k, v).name for k, v, _ in CASES.values()} == set(MOTIONS)
    assert motion_kind("uniform", _field()) is MOTIONS["field"]
    with pytest.raises(ValueError, match="goes with kind='uniform'"):
        motion_kind("rotation", _field())
    # every kind has command-line options
    assert set(MOTION_OPTIONS) == set(KINDS)


# --------------------------------------------------------------------------------------
# Dask: chunked == unchunked == motion_blur, and the chunk layout of each kind
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("psf", PSFS)
@pytest.mark.parametrize("case", CASES)
def test_dask_matches_motion_blur(case, psf):
    kind, velocity, center = CASES[case]
    stack = np.stack([_image(seed=2), _image(seed=3)])
    displace = case not in ("uniform-cols", "zoom-out-two-rates", "rotation")   # some blurred in place
    kw = dict(kind=kind, psf=psf, center=center, displace=displace, mode="nearest")
    ref = motion_blur(stack, velocity, backend="numpy", **kw)
    chunks = ((1, 1), (10, 14), (12, 18))
    lazy = gd.motion_blur(da.from_array(stack, chunks=chunks), velocity, backend="numpy", **kw)
    assert lazy.chunks == _expected_chunks(case, psf, chunks)
    chunked = lazy.compute(scheduler="synchronous")
    whole = gd.motion_blur(da.from_array(stack, chunks=stack.shape), velocity, backend="numpy",
                           **kw).compute(scheduler="synchronous")
    assert chunked.shape == stack.shape and chunked.dtype == ref.dtype
    _close(chunked, ref)
    _close(whole, ref)
    assert not np.allclose(ref, stack, atol=1e-3)      # the motion did something


def test_dask_field_needs_the_image_plane_and_refuses_before_any_task():
    x = da.from_array(np.stack([_image(), _image(seed=4)]), chunks=(1, 12, 15))
    with pytest.raises(ValueError, match=r"\(2, H, W\) = \(2, 24, 30\).*got \(2, 24, 31\)"):
        gd.motion_blur(x, np.zeros((2, H, W + 1)), backend="numpy")
    with pytest.raises(ValueError, match="velocity field must be finite"):
        gd.motion_blur(x, np.full((2, H, W), np.nan), backend="numpy")
    with pytest.raises(ValueError, match="goes with kind='uniform'"):
        gd.motion_blur(x, _field(), kind="zoom", backend="numpy")
    with pytest.raises(ValueError, match="inside the image"):          # zoom: its centre, before compute
        gd.motion_blur(x, 0.2, kind="zoom", center=(-3.0, 5.0), backend="numpy")
    with pytest.raises(ValueError, match="within"):                    # rotation: within twice the diagonal
        gd.motion_blur(x, 10.0, kind="rotation", center=(500.0, 20.0), backend="numpy")
    with pytest.raises(ValueError, match=r"u1\) must lie in"):
        gd.motion_blur(x, 2.5, kind="zoom", backend="numpy")


def test_dask_field_with_channel_axis():
    rgb = np.stack([_image(seed=s) for s in (5, 6, 7)], axis=-1)
    field = _field(8)
    out = gd.motion_blur(da.from_array(rgb, chunks=(8, 10, 3)), field, psf="box", channel_axis=-1,
                         backend="numpy").compute(scheduler="synchronous")
    _close(out, motion_blur(rgb, field, psf="box", channel_axis=-1, backend="numpy"))


# --------------------------------------------------------------------------------------
# synthesize_motion: frame k is motion_blur at t = k / (n - 1), with the psf
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("psf", PSFS)
@pytest.mark.parametrize("case", CASES)
def test_synthesize_motion_frames_with_psf(case, psf):
    kind, velocity, center = CASES[case]
    img = _image(seed=9)
    kw = dict(kind=kind, psf=psf, center=center, mode="reflect")
    frames = synthesize_motion(img, velocity, 3, backend="numpy", **kw)
    assert frames.shape == (3, H, W)
    for k, t in enumerate((0.0, 0.5, 1.0)):
        _close(frames[k], motion_blur(img, _velocity_at(kind, velocity, t), backend="numpy", **kw))
    # frame 0 is the input (a zero field still resamples the spline: rounding only)
    _close(frames[0], img, tol=1e-9 if case == "field" else 0.0)
    _close(frames[-1], motion_blur(img, velocity, backend="numpy", **kw), tol=1e-9)


def test_synthesize_motion_checks_everything_before_the_first_frame():
    img = _image()
    calls = []
    for velocity, kw, match in ((np.zeros((2, H, W + 1)), {}, r"\(2, H, W\)"),
                                (np.full((2, H, W), 5000.0), {}, "within ±4096"),
                                (10.0, dict(kind="rotation", center=(900.0, 0.0)), "within"),
                                (0.2, dict(kind="zoom", center=(H + 3.0, 4.0)), "inside the image")):
        with pytest.raises(ValueError, match=match):
            synthesize_motion(img, velocity, 4, backend="numpy", progress=lambda: calls.append(1), **kw)
    assert calls == []


# --------------------------------------------------------------------------------------
# gfgpu.batch and `gfgpu batch blur`
# --------------------------------------------------------------------------------------
BATCH_CASES = {
    "uniform": ({"velocity": (1.5, -2.25)}, dict(velocity=(1.5, -2.25))),
    "uniform-in-place": ({"velocity": (0.0, 3.0), "keep_position": True}, dict(velocity=(0.0, 3.0), displace=False)),
    "zoom": ({"zoom": 0.3, "center": (11, 14)}, dict(velocity=0.3, kind="zoom", center=(11, 14))),
    "zoom-two-rates": ({"zoom": (0.1, 0.25)}, dict(velocity=(0.1, 0.25), kind="zoom")),
    "rotation": ({"rotation": 25.0, "center": (10, None)},
                 dict(velocity=25.0, kind="rotation", center=(10, (W - 1) / 2))),
    "rotation-in-place": ({"rotation": -15.0, "keep_position": True},
                          dict(velocity=-15.0, kind="rotation", displace=False)),
}


@pytest.fixture
def rgb_png(tmp_path):
    rgb = (np.stack([_image(seed=s) for s in (10, 11, 12)], axis=-1) * 255).astype(np.uint8)
    path = tmp_path / "in.png"
    iio.imwrite(path, rgb)
    return path, rgb


@pytest.mark.parametrize("psf", PSFS)
@pytest.mark.parametrize("case", BATCH_CASES)
def test_batch_blur_matches_motion_blur(rgb_png, tmp_path, case, psf):
    path, rgb = rgb_png
    params, kw = BATCH_CASES[case]
    params = dict(params, psf=psf)
    batch.check_parameters("blur", params)
    out = tmp_path / "out" / "in.npy"
    result = batch.process_file(batch.Job(str(path), str(out), "blur", params, "npy", backend="numpy"))
    assert result.status == "ok", result.message
    ref = motion_blur(rgb.astype(np.float32), psf=psf, channel_axis=-1, backend="numpy", **kw)
    np.testing.assert_array_equal(np.load(out), ref)


def test_batch_command_offers_rotation_and_psf(rgb_png, tmp_path):
    path, rgb = rgb_png
    work = rgb.astype(np.float32)
    runs = ((["--rotate", 12, "--center-x", 16, "--center-y", 10, "--psf", "box"],
             dict(velocity=12.0, kind="rotation", center=(10.0, 16.0), psf="box")),
            (["--zoom", 0.2, "--keep-position", "--psf", "box"], dict(velocity=0.2, kind="zoom", psf="box",
                                                                       displace=False)),
            (["--dx", 3, "--psf", "box"], dict(velocity=(0.0, 3.0), psf="box")))
    for i, (argv, kw) in enumerate(runs):
        outdir = tmp_path / f"o{i}"
        assert main(["batch", "blur", str(path), "-o", str(outdir), *map(str, argv), "--format", "npy",
                     "--backend", "numpy", "-q"]) == 0
        np.testing.assert_array_equal(np.load(outdir / "in.npy"),
                                      motion_blur(work, channel_axis=-1, backend="numpy", **kw))


def test_batch_refuses_a_field_and_misplaced_center():
    with pytest.raises(ValueError, match="velocity field"):
        batch.check_parameters("blur", {"velocity": np.zeros((2, 24, 24))})
    with pytest.raises(ValueError, match="center=.*applies to rotation and zoom only"):
        batch.check_parameters("blur", {"velocity": (1, 1), "center": (3, 3)})
    with pytest.raises(ValueError, match="exactly one of velocity=.*zoom=.*rotation=.*got zoom and rotation"):
        batch.check_parameters("blur", {"zoom": 0.1, "rotation": 3.0})


# --------------------------------------------------------------------------------------
# the commands: gfgpu blur and gfgpu frames, every kind and psf
# --------------------------------------------------------------------------------------
CLI_CASES = {
    "uniform": (["--dx", -2.25, "--dy", 1.5], dict(velocity=(1.5, -2.25))),
    "zoom": (["--zoom", 0.3, "--center-x", 14, "--center-y", 11], dict(velocity=0.3, kind="zoom", center=(11, 14))),
    "rotation": (["--rotate", 25, "--center-x", 16], dict(velocity=25.0, kind="rotation",
                                                           center=((H - 1) / 2, 16))),
}


def test_cli_cases_cover_the_kinds():
    assert {kw.get("kind", "uniform") for _, kw in CLI_CASES.values()} == set(KINDS)


@pytest.mark.parametrize("psf", PSFS)
@pytest.mark.parametrize("case", CLI_CASES)
def test_blur_and_frames_commands_match_the_library(tmp_path, case, psf):
    argv, kw = CLI_CASES[case][0], dict(CLI_CASES[case][1])
    grey = _image(seed=13).astype(np.float32)
    tifffile.imwrite(tmp_path / "in.tif", grey)
    assert main(["blur", str(tmp_path / "in.tif"), "-o", str(tmp_path / "b.tif"), *map(str, argv), "--psf", psf,
                 "--backend", "numpy", "-q"]) == 0
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "b.tif"),
                                  motion_blur(grey, psf=psf, backend="numpy", **kw))
    png = (grey * 255).astype(np.uint8)
    iio.imwrite(tmp_path / "in.png", png)
    assert main(["frames", str(tmp_path / "in.png"), "-o", str(tmp_path / "f"), *map(str, argv), "-n", "3",
                 "--psf", psf, "--backend", "numpy", "-q"]) == 0
    work = png.astype(np.float32)
    velocity = kw.pop("velocity")
    for k, t in enumerate((0.0, 0.5, 1.0)):
        ref = motion_blur(work, _velocity_at(kw.get("kind", "uniform"), velocity, t), psf=psf,
                          backend="numpy", **kw)
        got = iio.imread(tmp_path / "f" / f"frame_00{k}.png").astype(int)
        assert np.abs(got - io.to_output(ref, png, "x.png").astype(int)).max() <= 1, (k, t)


def _subparser(*names):
    parser = build_parser()
    for name in names:
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = action.choices[name]
    return parser


def _option(parser, flag):
    return next(a for a in parser._actions if flag in a.option_strings)


@pytest.mark.parametrize("command", [("blur",), ("frames",), ("batch", "blur")])
def test_cli_psf_choices_are_the_table(monkeypatch, command):
    psf = _option(_subparser(*command), "--psf")
    assert tuple(psf.choices) == tuple(PSFS) and psf.default == "green"
    assert all(p.summary in psf.help for p in PSFS.values()) and psf.help == psf_help()
    # a PSF added to the table is offered at once (nothing hard-codes the names)
    monkeypatch.setitem(PSFS, "gauss", PointSpread("gauss", "a test entry"))
    assert tuple(_option(_subparser(*command), "--psf").choices) == ("green", "box", "gauss")


# --------------------------------------------------------------------------------------
# an unknown kind or psf, at every entry point: refused, the message lists the table's names
# --------------------------------------------------------------------------------------
def _lists(message, names):
    assert all(repr(n) in message or n in message for n in names), message


def test_unknown_kind_and_psf_are_refused_everywhere(tmp_path, capsys, rgb_png):
    img = _image()
    x = da.from_array(img, chunks=(12, 15))
    for call in (lambda **kw: motion_blur(img, (1.0, 1.0), backend="numpy", **kw),
                 lambda **kw: synthesize_motion(img, (1.0, 1.0), 3, backend="numpy", **kw),
                 lambda **kw: gd.motion_blur(x, (1.0, 1.0), backend="numpy", **kw)):
        with pytest.raises(ValueError, match="kind must be one of") as exc:
            call(kind="spin")
        _lists(str(exc.value), KINDS)
        with pytest.raises(ValueError, match="psf must be one of") as exc:
            call(psf="gauss")
        _lists(str(exc.value), PSFS)
    # gfgpu.batch: a psf the table lacks, a motion parameter no kind has
    with pytest.raises(ValueError, match="psf must be one of") as exc:
        batch.check_parameters("blur", {"velocity": (1, 1), "psf": "gauss"})
    _lists(str(exc.value), PSFS)
    with pytest.raises(ValueError, match="unknown 'spin'") as exc:
        batch.check_parameters("blur", {"spin": 3.0})
    _lists(str(exc.value), batch.BLUR_MOTIONS.values())
    path, _ = rgb_png
    failed = batch.process_file(batch.Job(str(path), str(tmp_path / "x.npy"), "blur",
                                          {"rotation": 3.0, "psf": "gauss"}, "npy", backend="numpy"))
    assert failed.status == "failed" and "psf must be one of" in failed.message
    # the commands: --psf lists the choices; no motion lists every kind's options
    for argv in (["blur", str(path), "-o", str(tmp_path / "o.png")],
                 ["frames", str(path), "-o", str(tmp_path / "f")],
                 ["batch", "blur", str(path), "-o", str(tmp_path / "b")]):
        with pytest.raises(SystemExit) as stop:
            main([*argv, "--dx", "1", "--psf", "gauss", "--backend", "numpy"])
        assert stop.value.code == 2
        _lists(capsys.readouterr().err, PSFS)
        assert main([*argv, "--backend", "numpy", "-q"]) == 2
        err = capsys.readouterr().err
        assert "give one motion" in err and all(usage in err for _, usage, _ in MOTION_OPTIONS.values()), err


# --------------------------------------------------------------------------------------
# on every backend: the Dask and frame entry points agree with motion_blur there
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["uniform-rows", "field", "rotation", "zoom-in"])
def test_entry_points_agree_on_every_backend(backend, case):
    kind, velocity, center = CASES[case]
    dtype = float_dtype(backend)
    tol = 1e-9 if dtype == np.float64 else 2e-5
    img = _image(seed=14).astype(dtype)
    for psf in PSFS:
        kw = dict(kind=kind, psf=psf, center=center, mode="nearest")
        ref = motion_blur(img, velocity, backend=backend.name, **kw)
        lazy = gd.motion_blur(da.from_array(img, chunks=(10, 12)), velocity, backend=backend.name, **kw)
        _close(lazy.compute(scheduler="synchronous"), ref, tol)
        frames = synthesize_motion(img, velocity, 2, backend=backend.name, **kw)
        _close(frames[1], ref, tol)


def test_a_kind_without_command_line_options_leaves_the_commands_working(monkeypatch, capsys):
    """A kind the table gains before the command line maps it is not offered there, and every
    command still starts (the test above, that every kind has options, is what asks for them)."""
    from gfgpu.cli import motion_args
    monkeypatch.setattr(motion_args, "KINDS", (*KINDS, "shake"))
    assert main(["devices"]) == 0
    capsys.readouterr()
    args = build_parser().parse_args(["blur", "x.png", "-o", "y.png", "--dx", "1"])
    assert motion_args.motion_kind_of(args) == "uniform"
    with pytest.raises(motion_args.CommandError, match="give one motion") as err:
        motion_args.motion_kind_of(build_parser().parse_args(["blur", "x.png", "-o", "y.png"]))
    assert "shake" not in str(err.value)
