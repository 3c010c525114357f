#!/usr/bin/env bash
# Regenerates every figure and result table of docs/RESULTS.md, from the
# commands a user would run. Deterministic except for compute times.
#
#   docs/make_figures.sh            # all (about 4 minutes on 2 cores, mostly the batches)
#
# Writes docs/figures/*.png and docs/results/*.txt|csv|json, then rewrites the
# generated tables of docs/RESULTS.md (docs/update_tables.py); the other numbers in docs/RESULTS.md
# are copied from docs/results by hand.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo build --release --bin oldbf
oldbf=target/release/oldbf
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
figs=docs/figures
results=docs/results
mkdir -p "$figs" "$results"

# Paper Fig. 5: B_l, B_r, v, ω over time on the line with dynamic obstacles.
"$oldbf" sim config/scenarios/paper_line.yaml --out "$tmp/line" | grep -v "  wrote" >"$results/paper_line.txt"
for f in trajectory barriers velocities; do cp "$tmp/line/$f.png" "$figs/paper_line_$f.png"; done

# Paper Fig. 6: v and ω on the circle.
"$oldbf" sim config/scenarios/paper_circle.yaml --out "$tmp/circle" | grep -v "  wrote" >"$results/paper_circle.txt"
for f in trajectory velocities; do cp "$tmp/circle/$f.png" "$figs/paper_circle_$f.png"; done

# Paper Fig. 9: circle tracking, DCBF vs OLDBF.
"$oldbf" compare config/scenarios/paper_circle.yaml --controllers oldbf,dcbf --out "$tmp/fig9" \
    | grep -v "^  wrote" >"$results/fig9_circle_oldbf_vs_dcbf.txt"
cp "$tmp/fig9/trajectories.png" "$figs/fig9_circle_trajectories.png"
cp "$tmp/fig9/tracking_error.png" "$figs/fig9_circle_tracking_error.png"
cp "$tmp/fig9/comparison.json" "$results/fig9_circle_oldbf_vs_dcbf.json"

# Every shipped scenario with every controller (the scenario tables of docs/RESULTS.md).
for s in config/scenarios/*.yaml; do
    name=$(basename "$s" .yaml)
    "$oldbf" compare "$s" --controllers oldbf,oldbf-paper,dcbf,vo,none >"$results/scenario_$name.txt"
done

# Paper contribution 2: minimum distance over 100 random worlds, obstacles
# slower and faster than the robot; and the project's own templates (movers on
# a collision course from the side, head-on and from behind, static clutter,
# mixed, doorways). Every controller, the paper's method (oldbf-paper) beside
# the default, on the same worlds.
for t in slow_obstacles fast_obstacles movers_crossing movers_head_on movers_overtaking mixed static_clutter doorways; do
    "$oldbf" batch "config/batch/$t.yaml" --worlds 100 --seed 1 \
        --controllers oldbf,oldbf-paper,dcbf,vo,none --out "$tmp/batch_$t" | grep -v "^wrote" >"$results/batch_$t.txt"
    cp "$tmp/batch_$t/min_clearance.png" "$figs/batch_${t}_min_clearance.png"
    cp "$tmp/batch_$t/comparison.csv" "$results/batch_$t.csv"
done
# The tables of docs/RESULTS.md, from the outputs above.
python3 docs/update_tables.py
echo "figures in $figs, tables in $results"
