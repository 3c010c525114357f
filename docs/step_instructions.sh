#!/bin/bash
# docs/step_instructions.sh BIN WORLD.yaml OUTDIR
#
# The safety path's instructions per control step of one simulated world,
# counted by callgrind: the node's tick (scan to command) less the way round
# (the local map's insert and the route's plan, which the node runs in a thread
# of its own). Instruction counts do not depend on what else the machine runs,
# unlike the batch's CPU-time figures; on the development VM one step's
# instructions and its CPU time correlate at 0.84-0.91.
#
# Writes OUTDIR/instr.csv (step, instr) and prints the median, p90, p99, max
# and mean. Needs valgrind; about a minute per world of 1000 steps.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 BIN WORLD.yaml OUTDIR" >&2; exit 2; }
command -v valgrind >/dev/null || { echo "valgrind is not installed" >&2; exit 1; }
BIN=$1 WORLD=$2 OUT=$3
rm -rf "$OUT"; mkdir -p "$OUT"
TICK=oldbf_ros::node_core::NodeCore::tick
PLAN=oldbf::algo::way_round::WayRound::plan
# Collection on inside a tick, off inside the map's insert; a dump before and after
# every plan and after every tick splits the run into the steps' parts.
valgrind --tool=callgrind --callgrind-out-file="$OUT/cg.out" --collect-atstart=no \
  --toggle-collect='*NodeCore::tick' --toggle-collect='*WayRound::insert' \
  --dump-before=$PLAN --dump-after=$PLAN --dump-after=$TICK \
  "$BIN" sim "$WORLD" --out "$OUT/sim" >/dev/null 2>&1
python3 - "$OUT" <<'P'
import glob, re, sys, os
out = sys.argv[1]
parts = []
for f in glob.glob(os.path.join(out, "cg.out.*")):
    m = re.search(r"\.(\d+)$", f)
    trig, total = "", 0
    for line in open(f):
        if line.startswith("desc: Trigger:"):
            trig = line
        elif line.startswith("summary:"):
            total = int(line.split()[1])
            break
    parts.append((int(m.group(1)), trig, total))
    os.remove(f)
parts.sort()
steps, cur, plan = [], 0, 0
for _, trig, total in parts:
    if "after" in trig and "WayRound::plan" in trig:
        plan += total  # a plan: beside the safety path
        continue
    cur += total
    if "NodeCore::tick" in trig:
        steps.append(cur)
        cur = 0
with open(os.path.join(out, "instr.csv"), "w") as o:
    o.write("step,instr\n")
    o.writelines(f"{i},{v}\n" for i, v in enumerate(steps))
x = sorted(steps)
q = lambda p: x[min(len(x) - 1, int(p * len(x)))]
print(f"{len(x)} steps: median {q(0.5)}, p90 {q(0.9)}, p99 {q(0.99)}, max {x[-1]}, "
      f"mean {sum(x) // len(x)} instructions; the way round's plans {plan} in all")
P
rm -f "$OUT/cg.out"
