"""The launch sizes of the recursion pass that docs/architecture.md states, recomputed.

The table in the doc (between the ``launch-table`` markers) must equal :func:`launch_table`, so
the documented sizes cannot drift from what the backends launch.
"""

from pathlib import Path

from gfgpu.backends.opencl.backend import recurse_launch
from gfgpu.backends.warp.backend import GPU_BLOCK_DIM, block_split

DOC = Path(__file__).resolve().parents[2] / "docs" / "architecture.md"
CASES = [("rows", 4096, 4096, 2), ("columns", 4096, 4096, 1), ("columns", 3000, 3000, 1), ("columns", 2048, 2048, 1),
         ("rows", 512, 512, 2), ("columns", 512, 512, 1), ("rows", 4, 4194304, 2)]
CPU_UNITS, CPU_CACHE, GPU_UNITS, GPU_GROUP = 2, 32 << 20, 132, 64   # PoCL's global_mem_cache_size here


def _items(gsize):
    total = 1
    for g in gsize:
        total *= g
    return total


def launch_table():
    """The Markdown table of the doc: one row per (pass, image), float32."""
    lines = ["| pass, float32 image | PoCL, 2 CPU cores, 32 MiB cache: work-items × lanes (band, blocks) | "
             "OpenCL GPU, 132 units: work-items (blocks) | Warp CUDA: threads (blocks), block_dim |",
             "|---|---|---|---|"]
    for name, h, w, axis in CASES:
        shape = (1, h, w)
        cpu = recurse_launch(shape, axis, 4, CPU_UNITS, "cpu", 1, cache=CPU_CACHE)
        gpu = recurse_launch(shape, axis, 4, GPU_UNITS, "gpu", GPU_GROUP)
        lines_, blocks, _ = block_split(shape, axis, "gpu")
        band = f"{cpu.vectors * cpu.lanes} columns" if axis == 1 else f"{cpu.lanes} rows"
        if cpu.rows_as_blocks:     # few long rows: the lanes hold blocks of a line
            band = f"{cpu.lanes} blocks of {cpu.block}"
        lines.append(f"| {name} of {h}×{w} | {_items(cpu.gsize)} × {cpu.lanes} ({band}, {cpu.blocks}) | "
                     f"{_items(gpu.gsize)} ({gpu.blocks}) | {lines_ * blocks} ({blocks}), {GPU_BLOCK_DIM} |")
    return "\n".join(lines)


def test_doc_states_the_launch_sizes():
    text = DOC.read_text()
    start, end = "<!-- launch-table -->", "<!-- /launch-table -->"
    assert start in text and end in text, "docs/architecture.md lost its launch table markers"
    documented = text.split(start, 1)[1].split(end, 1)[0].strip()
    assert documented == launch_table(), "docs/architecture.md launch table is stale:\n" + launch_table()


def test_column_bands_narrow_only_from_memory_on_whole_lines():
    """Bands of ``_DRAM_BAND`` vectors only when input and output exceed the cache and rows are
    whole cache lines or the pass streams (8 MiB of input); otherwise up to ``_BAND``; always two
    work-items per core at least."""
    from gfgpu.backends.opencl.backend import _BAND, _DRAM_BAND

    def band(h, w, itemsize=4, cache=CPU_CACHE, b=1):
        return recurse_launch((b, h, w), 1, itemsize, CPU_UNITS, "cpu", 1, cache=cache).vectors

    assert band(4096, 4096) == band(2048, 2048, 8) == band(3584, 3584) == _DRAM_BAND
    assert band(2048, 2048) == 32 and band(1024, 1024, b=4) == _BAND   # input and output fit the cache
    assert band(4096, 4096, cache=1 << 30) == _BAND
    # rows that end inside a cache line: narrow where the pass streams its stores (>= 8 MiB in)
    assert band(4095, 4095) == band(3000, 3000) == band(3000, 3001, 8) == _DRAM_BAND
    assert band(3000, 3000, cache=1 << 30) == 47 and band(1400, 1400, cache=0) == 22   # no streaming below 8 MiB
    assert band(8192, 256) == 4                                          # two bands per core
