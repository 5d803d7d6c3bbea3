"""``gfgpu devices``: every backend and device gfgpu can see, usable or not (and why)."""

from __future__ import annotations

from ..backends import devices


def add_parser(subparsers):
    p = subparsers.add_parser("devices", help="list backends and devices, usable or not (and why)")
    p.set_defaults(func=run)


def run(args):
    rows = devices()
    head = ("backend", "device", "kind", "state")
    table = [head] + [(d.backend, d.device, d.kind, "usable" if d.usable else f"unavailable: {d.note}")
                      for d in rows]
    widths = [max(len(r[i]) for r in table) for i in range(3)]
    for r in table:
        print("  ".join(c.ljust(w) for c, w in zip(r[:3], widths)) + "  " + r[3])
    return 0
