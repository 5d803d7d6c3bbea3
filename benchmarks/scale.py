"""Scale: cost per pixel versus image size, images larger than memory, and Dask.

(1) Throughput versus size: square float32 images (``--sizes``, default 1024² .. 16384²)
    through ``gfgpu.shift`` by (2.5, -1.5) (``--op gradient``: ``gfgpu.gradient`` u = 1) on
    each backend, host array in and out: best of N calls (N smaller for big sizes), Mpix/s,
    ns/pixel and the spread of ns/pixel across sizes (an O(N) operator keeps it flat);
    beside numpy.copyto of the same array (the memory bound) and scipy.ndimage.shift
    (order=1) (``--op gradient``: scipy.ndimage.sobel along both axes) up to ``--peer-max``.
    Every (size, backend) runs in its own fresh process, so its peak RSS is its own.
(2) The working-set proof: a ``--large`` ² float32 image (default 20000², 1.49 GiB) is
    written band by band to a temporary ``.npy`` (the generator never holds it), then each
    backend runs ``gfgpu.filter_npy`` ('shift' (2.5, -1.5) and 'derivative' u = 1,
    axis 0) with ``--working-set`` (default 256M) in a fresh process whose address space is
    capped by ``RLIMIT_AS`` before gfgpu is imported: ``--cap`` (default 1.5G, about the
    file's size), else the file's size plus ``--cap``, else no cap — each failure is
    reported.  The outputs are compared with the one-piece in-memory numpy call on the whole
    image (another process, whose time and peak RSS are reported too).  ``--profile`` adds a
    cProfile of the numpy shift.
(3) Dask (``gfgpu.dask.shift``, ``--dask-backend``): a batch of 16 images of 2048² (one
    chunk each) with the synchronous and threaded schedulers and ``distributed.LocalCluster``
    with one and two single-threaded worker processes, with distributed's default worker
    environment and without its ``MALLOC_TRIM_THRESHOLD_``; and one 8192² image in 2048²
    chunks (state carried across chunks) beside the in-memory call, with the largest
    difference.

Peak RSS is ``VmHWM`` of ``/proc/self/status`` in the measured process.  ``ru_maxrss`` is
not used: Linux keeps it across ``execve``, so a child started by a process holding N GB
reports at least N GB (with ``vfork`` the parent's own peak) — the children report both,
and they agree here only because the parent stays small.  The machine's load average is
printed with each part: on a shared machine timings vary by 2x between runs.

Usage:  python benchmarks/scale.py [--sizes 1024 2048 4096 8192 16384] [--backends numpy opencl warp]
        [--op shift|gradient] [--large 20000] [--working-set 256M] [--cap 1.5G] [--no-dask]
        [--profile] [--figure docs/scale.png] [--save results.json] [--replot results.json]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

SHIFT = (2.5, -1.5)
DEFAULT_SIZES = (1024, 2048, 4096, 8192, 16384)
DEFAULT_BACKENDS = ("numpy", "opencl", "warp")
LARGE_OPS = {"shift": {"shift": SHIFT}, "derivative": {"u": 1.0, "axis": 0}}
PEERS = ("numpy.copyto", "scipy")


# --------------------------------------------------------------------------------------
# measurements inside a child process
# --------------------------------------------------------------------------------------
def _status_kib(field):
    """A ``VmXXX`` field of /proc/self/status in KiB (None where /proc is absent)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def _memory():
    import resource
    return {"hwm_kib": _status_kib("VmHWM"), "vmpeak_kib": _status_kib("VmPeak"),
            "ru_maxrss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}


def _repeats(n):
    """Timed calls per size: fewer for the big images (their own noise is smaller)."""
    return 5 if n <= 2048 else 3 if n <= 8192 else 2


def child_size(spec):
    """Best time of ``spec['who']`` (a backend or a peer) on one ``n``² image, and peak RSS."""
    n, who, op = spec["n"], spec["who"], spec["op"]
    if who in ("numpy.copyto", "scipy"):
        from scipy import ndimage
        if who == "numpy.copyto":
            def call(img, out=None):
                np.copyto(out, img)
        elif op == "shift":
            def call(img, out=None):
                ndimage.shift(img, SHIFT, order=1, mode="reflect")
        else:
            def call(img, out=None):
                ndimage.sobel(img, axis=0), ndimage.sobel(img, axis=1)
    else:
        import gfgpu
        if op == "shift":
            def call(img, out=None):
                gfgpu.shift(img, SHIFT, backend=who)
        else:
            def call(img, out=None):
                gfgpu.gradient(img, 1.0, backend=who)
    small = np.ones((256, 256), np.float32)
    call(small, np.empty_like(small))          # compile / load kernels before measuring
    base = _status_kib("VmRSS")
    img = np.random.default_rng(0).random((n, n), dtype=np.float32)
    out = np.empty_like(img) if who == "numpy.copyto" else None
    times = []
    for _ in range(spec["repeat"]):
        t0 = time.perf_counter()
        call(img, out)
        times.append(time.perf_counter() - t0)
    result = dict(best=min(times), times=times, base_kib=base, **_memory())
    if who in ("warp", "opencl"):
        result["primitive"] = _primitive(who, img)       # after the memory reading: its buffers are extra
    return result


def _primitive(name, img):
    """Seconds of one shift pass (the recursion primitive) along rows and along columns, on
    device-resident arrays: the device's own cost, without host copies and allocations."""
    from gfgpu import greens
    from gfgpu._core import recursion
    from gfgpu.backends import get_backend
    be = get_backend(name)
    n = img.shape[0]
    src, dst = be.reshape(be.asarray(img), (1, n, n)), be.reshape(be.empty(img.shape, img.dtype), (1, n, n))
    plan = recursion.plan_pass(greens.shift_pass(SHIFT[0]), n, "reflect", img.dtype)
    seconds = {}
    for axis, label in ((2, "rows"), (1, "columns")):
        be.recurse(src, dst, axis, plan)
        be.synchronize()
        t0 = time.perf_counter()
        be.recurse(src, dst, axis, plan)
        be.synchronize()
        seconds[label] = time.perf_counter() - t0
    return seconds


def child_large(spec):
    """One ``filter_npy`` run under an optional address-space cap (set before importing gfgpu)."""
    import resource
    if spec.get("cap"):
        resource.setrlimit(resource.RLIMIT_AS, (spec["cap"], spec["cap"]))
    import gfgpu
    from gfgpu import filter_npy
    gfgpu.shift(np.ones((64, 64), np.float32), SHIFT, backend=spec["backend"])   # kernels built
    t0 = time.perf_counter()
    info = filter_npy(spec["op"], spec["src"], spec["dst"], working_set=spec["working_set"],
                      backend=spec["backend"], **LARGE_OPS[spec["op"]])
    wall = time.perf_counter() - t0
    return dict(wall=wall, info={k: (list(v) if isinstance(v, tuple) else v) for k, v in info.items()},
                **_memory())


def child_profile(spec):
    """cProfile of one numpy ``filter_npy`` run: the top entries by own time and cumulative."""
    import cProfile
    import io
    import pstats

    from gfgpu import filter_npy
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.runcall(filter_npy, spec["op"], spec["src"], spec["dst"], working_set=spec["working_set"],
                 backend="numpy", **LARGE_OPS[spec["op"]])
    wall = time.perf_counter() - t0
    text = io.StringIO()
    stats = pstats.Stats(prof, stream=text)
    stats.sort_stats("tottime").print_stats(14)
    stats.sort_stats("cumulative").print_stats(14)
    return dict(wall=wall, text=text.getvalue())


def _compare(out_path, ref, band=1000):
    """‖out − ref‖/‖ref‖, max |out − ref| and the count of non-finite outputs of a .npy file
    against an array, in bands (NaN/inf outputs are counted, the norms are over the rest)."""
    out = np.load(out_path, mmap_mode="r")
    if out.shape != ref.shape:
        return dict(rel=float("nan"), max_abs=float("nan"), nonfinite=-1)
    num = den = peak = 0.0
    bad = 0
    for r0 in range(0, ref.shape[0], band):
        r = np.asarray(ref[r0:r0 + band], np.float64)
        d = np.asarray(out[r0:r0 + band], np.float64) - r
        finite = np.isfinite(d)
        bad += int(d.size - np.count_nonzero(finite))
        d = np.where(finite, d, 0.0)
        num, den = num + float(np.sum(d * d)), den + float(np.sum(r * r))
        peak = max(peak, float(np.abs(d).max()))
    del out
    return dict(rel=(num / den) ** 0.5 if den else float("nan"), max_abs=peak, nonfinite=bad)


def child_verify(spec):
    """One-piece in-memory numpy references (timed, with their peak RSS) against the strip outputs."""
    import gfgpu
    src = np.load(spec["src"])
    result = {}
    for op, outputs in spec["outputs"].items():
        t0 = time.perf_counter()
        if op == "shift":
            ref = gfgpu.shift(src, SHIFT, backend="numpy")
        else:
            ref = gfgpu.derivative(src, backend="numpy", **LARGE_OPS[op])
        wall = time.perf_counter() - t0
        result[op] = dict(wall=wall, hwm_kib=_status_kib("VmHWM"),
                          compare={name: _compare(path, ref) for name, path in outputs.items()})
        del ref
    return result


CHILDREN = {"size": child_size, "large": child_large, "profile": child_profile, "verify": child_verify}


def run_child(kind, spec, timeout=1200):
    """Run ``CHILDREN[kind](spec)`` in a fresh interpreter; (result dict, None) or (None, error)."""
    env = dict(os.environ)
    env.pop("GFGPU_WORKING_SET", None)      # part (1) measures one-piece calls
    payload = json.dumps({"kind": kind, "spec": spec})
    try:
        res = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", payload],
                             capture_output=True, text=True, env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, f"timed out after {timeout} s"
    for line in reversed(res.stdout.splitlines()):
        if line.startswith("RESULT "):
            return json.loads(line[7:]), None
    tail = (res.stderr.strip().splitlines() or [f"exit status {res.returncode}"])[-1]
    return None, f"exit status {res.returncode}: {tail}"


# --------------------------------------------------------------------------------------
# (1) throughput versus size
# --------------------------------------------------------------------------------------
def available_backends(names):
    from gfgpu.backends import get_backend
    usable = []
    for name in names:
        try:
            get_backend(name)
            usable.append(name)
        except Exception as exc:   # report and go on with the others
            print(f"# backend {name}: unavailable ({exc})", file=sys.stderr)
    return usable


def part_sizes(sizes, backends, op, peer_max):
    rows, skipped = [], []
    for n in sizes:
        for who in ("numpy.copyto", *backends, "scipy"):
            if who == "scipy" and n > peer_max:
                skipped.append(n)
                continue
            spec = dict(n=n, who=who, op=op, repeat=_repeats(n))
            result, error = run_child("size", spec)
            if error:
                print(f"# {who} at {n}²: {error}", file=sys.stderr)
                continue
            rows.append(dict(n=n, who=who, **result))
            print(f"#   {n:>6}² {who:<13} {result['best']:8.3f} s  peak RSS {result['hwm_kib'] / 1024:8.0f} MiB",
                  file=sys.stderr, flush=True)
    return rows, skipped


def _who_label(who, op):
    if who == "numpy.copyto":
        return "numpy.copyto (bound)"
    if who == "scipy":
        return "scipy.ndimage.shift order=1" if op == "shift" else "scipy.ndimage.sobel ×2"
    return f"gfgpu {who}"


def table_sizes(rows, op, skipped, peer_max):
    copy = {r["n"]: r["best"] for r in rows if r["who"] == "numpy.copyto"}
    lines = ["| size | who | best (s) | Mpix/s | ns/pixel | × copy time | peak RSS (MiB) | "
             "(peak − base) / image |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        n, pix = r["n"], r["n"] ** 2
        image = 4 * pix
        extra = (r["hwm_kib"] - r["base_kib"]) * 1024 / image
        ratio = r["best"] / copy[n] if n in copy else float("nan")
        lines.append(f"| {n}² | {_who_label(r['who'], op)} | {r['best']:.4f} | {pix / r['best'] / 1e6:,.0f} | "
                     f"{r['best'] / pix * 1e9:.1f} | {ratio:.1f} | {r['hwm_kib'] / 1024:,.0f} | {extra:.1f} |")
    spread = ["| who | ns/pixel min | ns/pixel max | max/min | sizes |", "|---|---:|---:|---:|---|"]
    for who in dict.fromkeys(r["who"] for r in rows):
        ns = [r["best"] / r["n"] ** 2 * 1e9 for r in rows if r["who"] == who]
        sizes = [r["n"] for r in rows if r["who"] == who]
        spread.append(f"| {_who_label(who, op)} | {min(ns):.1f} | {max(ns):.1f} | {max(ns) / min(ns):.2f} | "
                      f"{min(sizes)}²–{max(sizes)}² |")
    prim = [r for r in rows if "primitive" in r]
    if prim:
        spread += ["", "The recursion primitive alone (one shift pass on device-resident arrays, no host copies or "
                   "allocations), ns/pixel:", "", "| size | backend | rows | columns |", "|---|---|---:|---:|"]
        for r in prim:
            pix = r["n"] ** 2
            spread.append(f"| {r['n']}² | {r['who']} | {r['primitive']['rows'] / pix * 1e9:.1f} | "
                          f"{r['primitive']['columns'] / pix * 1e9:.1f} |")
    note = ""
    if skipped:
        note = (f"\nscipy peer skipped above {peer_max}² (about 10 s per call at 16384²; "
                f"`--peer-max` raises the limit): sizes {', '.join(f'{n}²' for n in sorted(set(skipped)))}.\n")
    return "\n".join(lines) + "\n\nns/pixel across sizes (flat = cost linear in pixels):\n\n" + \
        "\n".join(spread) + "\n" + note


# --------------------------------------------------------------------------------------
# (2) a large image under a working-set limit
# --------------------------------------------------------------------------------------
def write_large(path, n, band=1000):
    """A ``n``² float32 .npy written band by band (only one band in memory)."""
    header = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32, shape=(n, n))
    offset = header.offset
    del header                                   # header written, file sized; nothing mapped now
    rng = np.random.default_rng(1)
    x = np.linspace(0.0, 1.0, n, dtype=np.float32)
    with open(path, "r+b") as f:
        f.seek(offset)
        for r0 in range(0, n, band):
            r1 = min(n, r0 + band)
            rows = rng.random((r1 - r0, n), dtype=np.float32)
            rows += x[None, :] + x[r0:r1, None]  # a ramp, so boundary states are not trivial
            f.write(memoryview(rows).cast("B"))


def _gib(nbytes):
    return f"{nbytes / 2**30:.2f} GiB"


def _signal_name(error):
    """'SIGSEGV' for an error string that reports exit status -11, else the error."""
    import signal
    if error.startswith("exit status -"):
        try:
            return f"killed by {signal.Signals(int(error.split()[2].rstrip(':').lstrip('-'))).name}"
        except (ValueError, IndexError):
            pass
    return error


def part_large(n, backends, working_set, cap, tmp, profile):
    """filter_npy runs on a large .npy under address-space caps: ``cap``, then file size + ``cap``
    (a cap the one-piece call, which holds input and output, still cannot meet), then none."""
    from gfgpu._core.strips import parse_bytes
    src = os.path.join(tmp, "large.npy")
    t0 = time.perf_counter()
    write_large(src, n)
    file_bytes = os.path.getsize(src)
    print(f"# wrote {n}² float32 ({_gib(file_bytes)}) in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    cap_bytes = parse_bytes(cap, "cap") if cap and cap != "none" else None
    tiers = [cap_bytes, file_bytes + cap_bytes, None] if cap_bytes else [None]
    runs, outputs = [], {op: {} for op in LARGE_OPS}
    for op in LARGE_OPS:
        for be in backends:
            dst = os.path.join(tmp, f"{op}_{be}.npy")
            failures = []
            for tier in tiers:
                spec = dict(op=op, backend=be, src=src, dst=dst, working_set=working_set, cap=tier)
                result, error = run_child("large", spec)
                if not error:
                    break
                failures.append((tier, _signal_name(error)[:160]))
                print(f"# {op} {be} under RLIMIT_AS={_gib(tier) if tier else 'none'}: {_signal_name(error)}",
                      file=sys.stderr, flush=True)
            if error:
                runs.append(dict(op=op, backend=be, cap=None, failures=failures, failed=True))
                continue
            outputs[op][be] = dst
            runs.append(dict(op=op, backend=be, cap=tier, failures=failures, failed=False, **result))
            print(f"#   {op:<10} {be:<7} {result['wall']:7.1f} s  peak RSS {result['hwm_kib'] / 1024:6.0f} MiB  "
                  f"cap {_gib(tier) if tier else 'none'}", file=sys.stderr, flush=True)
    verify, error = run_child("verify", dict(src=src, outputs=outputs), timeout=3600)
    if error:
        print(f"# verification failed: {error}", file=sys.stderr)
    prof = None
    if profile:
        prof, error = run_child("profile", dict(op="shift", src=src, dst=os.path.join(tmp, "profile.npy"),
                                                working_set=working_set))
        if error:
            print(f"# profile failed: {error}", file=sys.stderr)
    return dict(n=n, runs=runs, verify=verify, profile=prof, cap=cap_bytes, file_bytes=file_bytes,
                working_set=parse_bytes(working_set))


def table_large(large):
    n = large["n"]
    pix = n * n
    ws = large["working_set"]
    verify = large["verify"] or {}
    caps = f"{_gib(large['cap'])}, else file size + {_gib(large['cap'])}, else none" if large["cap"] else "none"
    lines = [f"{n}² float32 ({_gib(large['file_bytes'])} .npy), working set {ws / 2**20:.0f} MiB; address-space "
             f"cap (RLIMIT_AS, set in the fresh process before gfgpu is imported): {caps}.", "",
             "| operation | backend | strips | cap it ran under | wall (s) | Mpix/s | peak RSS (MiB) | "
             "‖out − ref‖/‖ref‖ | max abs diff | non-finite |", "|---|---|---:|---|---:|---:|---:|---:|---:|---:|"]
    notes = []
    for r in large["runs"]:
        failed = "; ".join(f"{_gib(c) if c else 'no cap'}: {e}" for c, e in r["failures"])
        if failed:
            notes.append(f"{r['op']} {r['backend']}: {failed}")
        mark = f" [{len(notes)}]" if failed else ""
        if r["failed"]:
            lines.append(f"| {r['op']} | {r['backend']} | | failed{mark} | | | | | | |")
            continue
        cmp = verify.get(r["op"], {}).get("compare", {}).get(r["backend"], {})
        lines.append(f"| {r['op']} | {r['backend']} | {r['info']['strips']} × {r['info']['strip_rows']} rows | "
                     f"{_gib(r['cap']) if r['cap'] else 'none'}{mark} | {r['wall']:.1f} | "
                     f"{pix / r['wall'] / 1e6:.1f} | {r['hwm_kib'] / 1024:,.0f} | {cmp.get('rel', float('nan')):.1e} | "
                     f"{cmp.get('max_abs', float('nan')):.1e} | {cmp.get('nonfinite', '?')} |")
    for op, v in verify.items():
        lines.append(f"| {op}, one piece in memory (reference) | numpy | 1 | none | {v['wall']:.1f} | "
                     f"{pix / v['wall'] / 1e6:.1f} | {v['hwm_kib'] / 1024:,.0f} | — | — | — |")
    lines.append("")
    lines.append("Reference: the in-memory numpy call on the whole image (np.load), in a separate process; its "
                 "peak RSS includes the loaded input. Strip outputs of every backend are compared with it.")
    if notes:
        lines += ["", "Failed attempts:", ""] + [f"{i}. {t}" for i, t in enumerate(notes, 1)]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------
# (3) Dask
# --------------------------------------------------------------------------------------
def part_dask(backend, batch, size, big, chunk):
    """Batch throughput per scheduler, and a chunked image against the in-memory call.

    Every timed run gets a graph of its own (the shift differs by 1e-7 px per repetition):
    a distributed scheduler may still hold the keys of the previous identical graph.
    """
    import logging

    import dask
    import dask.array as da
    import distributed

    import gfgpu
    import gfgpu.dask as gd

    load = os.getloadavg()[0]
    logging.getLogger("distributed").setLevel(logging.ERROR)
    rng = np.random.default_rng(2)
    stack = rng.random((batch, size, size), dtype=np.float32)
    repeats = 3
    rows = []

    def shift_of(k):
        return (0.0, SHIFT[0], SHIFT[1] + 1e-7 * k)

    def best(run):
        times = []
        for k in range(1, repeats + 1):
            t0 = time.perf_counter()
            run(k)
            times.append(time.perf_counter() - t0)
        return min(times)

    rows.append(("loop of gfgpu.shift calls (no dask)",
                 best(lambda k: [gfgpu.shift(img, shift_of(k)[1:], backend=backend) for img in stack])))
    x = da.from_array(stack, chunks=(1, size, size))
    for scheduler, kw in (("synchronous", {}), ("threads", {"num_workers": 2})):
        rows.append((f"dask {scheduler}" + (" (2 threads)" if kw else ""),
                     best(lambda k, s=scheduler, kw=kw: dask.persist(gd.shift(x, shift_of(k), backend=backend),
                                                                     scheduler=s, **kw))))
    # distributed's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers, which turns off
    # glibc's dynamic mmap threshold: every large temporary is mapped (page faults) afresh
    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ"))
    plain = {k: v for k, v in environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
    saved_environ = dict(os.environ)
    for workers, env in ((1, environ), (2, environ), (1, plain), (2, plain)):
        label = "" if env is environ else ", no MALLOC_TRIM_THRESHOLD_"
        # LocalCluster leaves its pre-spawn environment in this process's os.environ, where
        # later clusters' workers inherit it: start each cluster from the original one
        os.environ.clear()
        os.environ.update(saved_environ)
        with dask.config.set({"distributed.nanny.pre-spawn-environ": env}), \
                distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                         dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
                distributed.Client(cluster) as client:
            # the images are made on the workers (no 256 MB graph), before the clock starts
            xs = da.random.default_rng(2).random((batch, size, size), dtype=np.float32, chunks=(1, size, size))
            xs = client.persist(xs)
            distributed.wait(xs)
            distributed.wait(client.persist(gd.shift(xs, shift_of(0), backend=backend)))   # workers warm
            rows.append((f"LocalCluster {workers} worker{'s' if workers > 1 else ''} × 1 thread{label}",
                         best(lambda k, c=client, y=xs: distributed.wait(
                             c.persist(gd.shift(y, shift_of(k), backend=backend))))))

    os.environ.clear()
    os.environ.update(saved_environ)

    img = rng.random((big, big), dtype=np.float32)
    t0 = time.perf_counter()
    ref = gfgpu.shift(img, SHIFT, backend=backend)
    one = time.perf_counter() - t0
    chunked = []
    xb = da.from_array(img, chunks=(chunk, chunk))
    for scheduler, kw in (("synchronous", {}), ("threads", {"num_workers": 2})):
        t0 = time.perf_counter()
        out = gd.shift(xb, SHIFT, backend=backend).compute(scheduler=scheduler, **kw)
        chunked.append((f"dask {scheduler}{' (2 threads)' if kw else ''}, {chunk}² chunks",
                        time.perf_counter() - t0, float(np.abs(out - ref).max())))
    return dict(rows=rows, batch=batch, size=size, big=big, chunk=chunk, one=one, chunked=chunked,
                backend=backend, repeats=repeats, load=(load, os.getloadavg()[0]))


def table_dask(res):
    pix = res["batch"] * res["size"] ** 2
    sync = dict(res["rows"])["dask synchronous"]
    times = dict(res["rows"])
    lines = [f"Load average during the Dask runs: {res['load'][0]:.1f} → {res['load'][1]:.1f} (2 cores).", "",
             f"Batch: {res['batch']} images of {res['size']}² float32, one chunk each, `gfgpu.dask.shift` "
             f"(0, {SHIFT[0]}, {SHIFT[1]}), backend {res['backend']}, best of {res['repeats']}:", "",
             "| how | wall (s) | Mpix/s | speed-up vs synchronous | vs 1 worker |", "|---|---:|---:|---:|---:|"]
    for name, t in res["rows"]:
        one = times.get(name.replace("2 workers", "1 worker"))
        vs1 = f"{one / t:.2f}" if name.startswith("LocalCluster") and one else ""
        lines.append(f"| {name} | {t:.2f} | {pix / t / 1e6:.0f} | {sync / t:.2f} | {vs1} |")
    big = res["big"]
    lines += ["", f"One {big}² image in {res['chunk']}² chunks (state carried across chunks along both axes) "
              "beside the in-memory call:", "",
              "| how | wall (s) | Mpix/s | max abs diff vs in-memory |", "|---|---:|---:|---:|",
              f"| gfgpu.shift in memory | {res['one']:.2f} | {big * big / res['one'] / 1e6:.0f} | — |"]
    for name, t, diff in res["chunked"]:
        lines.append(f"| {name} | {t:.2f} | {big * big / t / 1e6:.0f} | {diff:.1e} |")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------
# figure
# --------------------------------------------------------------------------------------
COLORS = {"numpy": "C0", "opencl": "C1", "warp": "C2"}


def figure(rows, large, op, path):
    """ns/pixel versus size (with the copy bound and the primitive alone) and peak RSS versus size."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11.5, 5.2))
    for who in dict.fromkeys(r["who"] for r in rows):
        mine = [r for r in rows if r["who"] == who]
        n = np.array([r["n"] for r in mine], float)
        ns = np.array([r["best"] / r["n"] ** 2 * 1e9 for r in mine])
        rss = np.array([r["hwm_kib"] / 1024 for r in mine])
        style = dict(color="k", ls="--", marker="s") if who == "numpy.copyto" else \
            dict(color="0.5", ls=":", marker="^") if who == "scipy" else dict(marker="o", color=COLORS.get(who))
        ax.plot(n * n / 1e6, ns, label=_who_label(who, op), **style)
        ax2.plot(4 * n * n / 2**20, rss, label=_who_label(who, op), **style)
        if all("primitive" in r for r in mine):
            prim = np.array([sum(r["primitive"].values()) / r["n"] ** 2 * 1e9 for r in mine])
            ax.plot(n * n / 1e6, prim, ls="-.", lw=1, marker=".", color=COLORS.get(who), alpha=0.7,
                    label=f"{who}: 2 passes on device arrays")
    if large:
        for r in large["runs"]:
            if r["op"] == "shift" and not r["failed"]:
                ax2.plot(4 * large["n"] ** 2 / 2**20, r["hwm_kib"] / 1024, marker="*", ms=13, ls="none",
                         color=COLORS.get(r["backend"]), markeredgecolor="k",
                         label=f"{large['n']}² from .npy in strips, {r['backend']}")
    ax.set(xscale="log", yscale="log", xlabel="image size (Mpix)", ylabel="ns per pixel",
           title=f"gfgpu.{op}: time per pixel (float32, host array in/out)")
    ax2.set(xscale="log", yscale="log", xlabel="image size (MiB, float32)", ylabel="peak RSS (MiB)",
            title="peak memory of the process (VmHWM)")
    for a in (ax, ax2):
        a.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"# wrote {path}", file=sys.stderr)


# --------------------------------------------------------------------------------------
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=list(DEFAULT_SIZES))
    ap.add_argument("--backends", nargs="+", default=list(DEFAULT_BACKENDS))
    ap.add_argument("--op", choices=("shift", "gradient"), default="shift")
    ap.add_argument("--peer-max", type=int, default=8192, help="largest size for the scipy peer")
    ap.add_argument("--large", type=int, default=20000, help="side of the large image (0 skips)")
    ap.add_argument("--working-set", default="256M")
    ap.add_argument("--cap", default="1.5G", help="RLIMIT_AS of the strip processes ('none': no cap)")
    ap.add_argument("--profile", action="store_true", help="cProfile the large numpy shift")
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--dask-backend", default="numpy")
    ap.add_argument("--figure", default=os.path.join(os.path.dirname(__file__), "..", "docs", "scale.png"),
                    help="figure path ('' skips)")
    ap.add_argument("--tmp", default=None, help="directory for the large files (default: a new one in /tmp)")
    ap.add_argument("--save", help="write the raw results to this JSON file")
    ap.add_argument("--replot", help="only redraw the figure from a --save JSON file")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.child:
        payload = json.loads(args.child)
        result = CHILDREN[payload["kind"]](payload["spec"])
        print("RESULT " + json.dumps(result), flush=True)
        return

    if args.replot:
        with open(args.replot) as f:
            saved = json.load(f)
        figure(saved["rows"], saved["large"], saved["op"], args.figure)
        return

    start = time.perf_counter()
    backends = available_backends(args.backends)
    print(f"# machine: {os.cpu_count()} cores; backends {', '.join(backends)}", file=sys.stderr)
    load = [os.getloadavg()[0]]
    rows, skipped = part_sizes(args.sizes, backends, args.op, args.peer_max) if args.sizes else ([], [])
    load.append(os.getloadavg()[0])

    large = None
    if args.large:
        tmp = tempfile.mkdtemp(prefix="gfgpu_scale_", dir=args.tmp)
        try:
            large = part_large(args.large, backends, args.working_set, args.cap, tmp, args.profile)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        load.append(os.getloadavg()[0])

    dask_res = None if args.no_dask else part_dask(args.dask_backend, 16, 2048, 8192, 2048)

    print(f"\n## Throughput versus size: gfgpu.{args.op}"
          f"{' by ' + str(SHIFT) if args.op == 'shift' else ' u = 1'}, float32, host array in and out\n")
    print(f"{os.cpu_count()} cores (shared: timings are noisy); each row in a fresh process; best of "
          f"{', '.join(f'{_repeats(n)} at {n}²' for n in args.sizes)}. Peak RSS = VmHWM of that process; "
          f"base = its RSS after imports and kernel build, before the image exists. Load average "
          f"{load[0]:.1f} → {load[1]:.1f}.\n")
    if rows:
        print(table_sizes(rows, args.op, skipped, args.peer_max))
    if large:
        print(f"## Larger than the working set: gfgpu.filter_npy on a {large['n']}² image\n")
        print(f"Load average {load[1]:.1f} → {load[2]:.1f}.\n")
        print(table_large(large))
        if large["profile"]:
            print(f"cProfile of the numpy shift ({large['profile']['wall']:.1f} s under the profiler):\n")
            print("```\n" + large["profile"]["text"].strip() + "\n```\n")
    if dask_res:
        print("## Dask\n")
        print(table_dask(dask_res))
    if args.save:
        with open(args.save, "w") as f:
            json.dump(dict(rows=rows, large=large, dask=dask_res, op=args.op, skipped=skipped), f, indent=1)
    if args.figure and rows:
        figure(rows, large, args.op, args.figure)
    print(f"# total {time.perf_counter() - start:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
