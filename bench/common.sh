# Shell helpers shared by the benchmark scripts (source it from the repository root).

# One line naming the machine, the date and the load, printed above every table.
machine_line() {
  echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(free -g | awk '/Mem:/ {print $2}') GiB, $(date -u +%Y-%m-%d), load $(cut -d' ' -f1 /proc/loadavg)"
}

# table_start COLUMN...: the machine line, then a Markdown table's head (the first column left,
# the others right-aligned).
table_start() {
  machine_line
  echo
  local head="|" rule="|" first=1
  for column in "$@"; do
    head+=" $column |"
    if [ $first = 1 ]; then rule+="---|"; first=0; else rule+="---:|"; fi
  done
  echo "$head"
  echo "$rule"
}

# fit_growth ROWS PATCH_COLUMN TIME_COLUMN MIN_PATCHES [NAME]: the exponent k of time ∝ patches^k, a
# least-squares line through log-log points, from the Markdown table rows in ROWS (columns counted
# as `split("|")` does: the first cell is column 1) with at least MIN_PATCHES patches. NAME (default
# "patches") names what the size column counts.
fit_growth() {
  [ -f "$1" ] || return 0
  python3 - "$@" <<'PY'
import math, sys
path, pc, tc, least = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
name = sys.argv[5] if len(sys.argv) > 5 else "patches"
rows = [line.split("|") for line in open(path)]
pts = [(int(r[pc]), float(r[tc])) for r in rows if int(r[pc]) >= least]
if len(pts) >= 2:
    xs = [math.log(p) for p, _ in pts]; ys = [math.log(t) for _, t in pts]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    k = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    print(f"\nfitted growth of wall time from {pts[0][0]} to {pts[-1][0]} {name}: n^{k:.2f}")
PY
}
