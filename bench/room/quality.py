"""How far bakes of issue 16's room are from a reference bake at what a viewer sees (probes.py's
points): per kind of surface, the RMS, largest and mean difference, relative to the reference's mean
over all probes but the lamp's face. Prints Markdown rows.

    python3 bench/room/quality.py PROBES.csv REF.csv [NAME=CAND.csv:REPORT.json ...]
"""
import json
import math
import sys

KINDS = ("floor", "wall", "ceiling", "suzanne", "sphere")


def luminance(path):
    rows = [line.split(",") for line in open(path).read().splitlines()[1:]]
    return [(float(r[3]) + float(r[4]) + float(r[5])) / 3 for r in rows]


kinds = json.load(open(sys.argv[1] + ".kinds.json"))
ref = luminance(sys.argv[2])
seen = [v for v, k in zip(ref, kinds) if k != "lamp"]
mean = sum(seen) / len(seen)
print("| bake | patches | s before export | RMS (all but the lamp) | " + " | ".join(KINDS) + " |")
print("|---|---:|---:|---:|" + "---:|" * len(KINDS))
for spec in sys.argv[3:]:
    name, rest = spec.split("=", 1)
    values, report = rest.split(":")
    r = json.load(open(report))
    diff = {}
    for v, w, k in zip(luminance(values), ref, kinds):
        diff.setdefault(k, []).append((v - w) / mean)
    everything = [d for k, ds in diff.items() if k != "lamp" for d in ds]

    def cell(ds):
        return "%.2f%% / %.1f%% / %+.2f%%" % (100 * math.sqrt(sum(d * d for d in ds) / len(ds)), 100 * max(map(abs, ds)),
                                               100 * sum(ds) / len(ds))
    seconds = r["timings"]["total"] - r["timings"]["export"]
    print("| %s | %d | %.1f | %s | %s |" % (name, r["counts"]["patches"], seconds, cell(everything),
                                            " | ".join(cell(diff[k]) for k in KINDS)))
print("\n(each cell: RMS / largest / mean difference, relative to the reference's mean over the probes, %.4f)" % mean)
