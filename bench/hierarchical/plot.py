#!/usr/bin/python3
"""Draws the hierarchical transport's scaling from the tables the benchmarks write:
bench/hierarchical/out/cornell.md (run.sh), bench/room/out/rooms.md (bench/room/run.sh) and
bench/hierarchical/out/engine.md (engine.sh). Wall time and peak memory against patches, log-log,
with issue 16's lines: n^1.2 growth (through the Cornell box at N = 20), 60 s and 10 minutes,
2 GiB and 8 GiB. Writes docs/images/hierarchical_scaling.png. A table that is missing is left out.

Usage: bench/hierarchical/plot.py"""
import re
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent.parent


def table(path):
    """The rows of the first Markdown table in `path` as dicts by column name (none for a missing file)."""
    if not path.exists():
        return []
    lines = [line.strip() for line in path.read_text().splitlines() if line.strip().startswith("|")]
    if len(lines) < 2:
        return []
    cells = lambda line: [c.strip() for c in line.strip("|").split("|")]  # noqa: E731
    head = cells(lines[0])
    return [dict(zip(head, cells(line))) for line in lines[2:]]


def number(cell):
    """A cell's leading number (thousands separators and a bracketed target dropped), or None."""
    match = re.match(r"[\d,]+(\.\d+)?", cell or "")
    return float(match.group(0).replace(",", "")) if match else None


def series(rows, size, value, keep=lambda row: True):
    points = [(number(r.get(size)), number(r.get(value))) for r in rows if keep(r)]
    return sorted((x, y) for x, y in points if x and y)


def main():
    cornell = table(ROOT / "bench/hierarchical/out/cornell.md")
    rooms = table(ROOT / "bench/room/out/rooms.md")
    engine = table(ROOT / "bench/hierarchical/out/engine.md")
    whole = lambda r: r.get("part (triangles asked)", "").startswith("whole")  # noqa: E731
    curves = [
        ("Cornell box, hierarchical", "o-", "C0", series(cornell, "patches", "hierarchical s"), series(cornell, "patches", "MiB")),
        ("Cornell box, exact", "x--", "C0", series(cornell, "patches", "exact s"), series(cornell, "patches", "exact MiB")),
        ("Blender rooms (Suzanne levels)", "s-", "C1", series(rooms, "patches", "wall s"), series(rooms, "patches", "peak MiB")),
        ("2CylinderEngine parts (--sky 1)", "^-", "C2", series(engine, "patches", "hierarchical s", lambda r: not whole(r)),
         series(engine, "patches", "MiB", lambda r: not whole(r))),
        ("2CylinderEngine parts, exact", "^--", "C2", series(engine, "patches", "exact s", lambda r: not whole(r)),
         series(engine, "patches", "exact MiB", lambda r: not whole(r))),
        ("whole 2CylinderEngine (default bake)", "*", "C3", series(engine, "patches", "hierarchical s", whole),
         series(engine, "patches", "MiB", whole)),
    ]
    if not any(t for _, _, _, t, _ in curves):
        sys.exit("bench/hierarchical/plot.py: no table to draw (run bench/hierarchical/run.sh first)")
    fig, (ax_t, ax_m) = plt.subplots(1, 2, figsize=(12, 5))
    for name, style, colour, times, memory in curves:
        if times:
            ax_t.loglog(*zip(*times), style, color=colour, label=name, markersize=8 if style == "*" else 5)
        if memory:
            ax_m.loglog(*zip(*memory), style, color=colour, label=name, markersize=8 if style == "*" else 5)
    xs = [x for _, _, _, t, m in curves for x, _ in t + m]
    lo, hi = min(xs) / 1.5, max(max(xs) * 1.5, 1.2e6)
    anchor = [p for p in series(cornell, "patches", "hierarchical s") if p[0] > 9000]
    if anchor:
        x0, y0 = anchor[0]
        ax_t.loglog([x0, hi], [y0, y0 * (hi / x0) ** 1.2], ":", color="grey", label="n^1.2 from Cornell N = 20 (issue 16's bound)")
    for seconds, label in ((60, "60 s"), (600, "10 minutes")):
        ax_t.axhline(seconds, color="grey", lw=0.8, ls="--")
        ax_t.text(lo * 1.1, seconds * 1.08, label, fontsize=8, color="grey")
    for mib, label in ((2048, "2 GiB"), (8192, "8 GiB")):
        ax_m.axhline(mib, color="grey", lw=0.8, ls="--")
        ax_m.text(lo * 1.1, mib * 1.08, label, fontsize=8, color="grey")
    for ax, what in ((ax_t, "wall time, s (2 cores)"), (ax_m, "peak memory, MiB")):
        ax.set_xlim(lo, hi)
        ax.set_xlabel("patches")
        ax.set_ylabel(what)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("radbake's hierarchical transport: time and memory against patches "
                 "(bench/hierarchical/run.sh, engine.sh, bench/room/run.sh)", fontsize=10)
    fig.tight_layout()
    out = ROOT / "docs/images/hierarchical_scaling.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
