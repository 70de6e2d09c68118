"""One Markdown row of bench/hierarchical/run.sh's and engine.sh's tables: the leading CELLs, then
the hierarchical bake's patches, wall time, peak MiB, near entries, far links, cluster rays and pair
rays (TMP/hierarchical.time, TMP/hierarchical.json), then the exact bake's time, MiB, the speed-up
and DIFF's RMS and largest (bench/hierarchical/compare.py's line; empty: dashes).
Usage: row.py TMP DIFF CELL..."""
import json
import sys

tmp, diff, cells = sys.argv[1], sys.argv[2], sys.argv[3:]
ht, hm = open(f"{tmp}/hierarchical.time").read().split()
r = json.load(open(f"{tmp}/hierarchical.json"))
s = r["solver"]
row = "| " + " | ".join(cells) + (f" | {r['counts']['patches']} | {float(ht):.1f} | {int(hm) // 1024} | {s['matrixEntries']} | "
                                  f"{s['farLinks']} | {s['clusterRays']} | {s['nearRays']} |")
if diff:
    et, em = open(f"{tmp}/exact.time").read().split()
    rms = diff.split("rms ")[1].split()[0]
    largest = diff.split("max ")[1].split()[0]
    row += f" {float(et):.1f} | {int(em) // 1024} | {float(et) / float(ht):.1f}x | {rms} | {largest} |"
else:
    row += " – | – | – | – | – |"
print(row)
