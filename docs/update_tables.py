#!/usr/bin/env python3
"""Rewrites the generated tables of docs/RESULTS.md from docs/results/.

    docs/update_tables.py            (docs/make_figures.sh runs it last)

Each table sits between `<!-- table:NAME -->` and `<!-- /table:NAME -->`;
everything else in the file is left alone. Tables:
  scenarios  every shipped scenario, OLDBF alone (oldbf sim --json)
  compare    every scenario, every controller (docs/results/scenario_*.txt)
  batch      every batch template, every controller (docs/results/batch_*.csv)
"""
import csv
import json
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "docs", "results")
DOC = os.path.join(ROOT, "docs", "RESULTS.md")
OLDBF = os.path.join(ROOT, "target", "release", "oldbf")

# What each shipped scenario tests (config/scenarios/NAME.yaml), in table order.
SCENARIOS = [
    ("paper_line", "paper Fig. 5: line at 0.15 m/s; a walker crossing ahead, a slower one to overtake, a crate on the line"),
    ("paper_circle", "paper Fig. 6: v_r = 0.2 m/s, ω_r = 0.13 rad/s (R = 1.54 m); a box and a pillar on the circle"),
    ("corridor", "1.6 m corridor, cabinets on alternate walls, start off-centre: the differential law centres, no both-sides turn"),
    ("dead_end", "constant 0.15 m/s into a cul-de-sac: the both-sides ω_0 turn takes the robot round and out"),
    ("crossing", "four obstacles crossing ahead of the robot from both sides"),
    ("cluttered_room", "8 × 6 m room, seven static obstacles, two movers off the line"),
    ("two_robots", "two robots on crossing lines, timed to meet: each is the other's obstacle (the ROS multi-robot test, 5 runs)"),
    ("two_robots_offset", "the same with robot2 0.5 m further back: it gives way"),
]
# Batch templates (config/batch/NAME.yaml), in table order.
TEMPLATES = [
    ("slow_obstacles", "slow movers (0.3–0.9 × v_r)"),
    ("fast_obstacles", "fast movers (1.1–2.0 × v_r)"),
    ("movers_crossing", "movers crossing from the side"),
    ("movers_head_on", "movers head-on"),
    ("movers_overtaking", "movers from behind (overtaking)"),
    ("mixed", "mixed: clutter and movers"),
    ("static_clutter", "static clutter (5–15 obstacles)"),
    ("doorways", "doorways (wide and narrow)"),
]
CONTROLLERS = ["oldbf", "oldbf-paper", "dcbf", "vo", "none"]


def scenarios_table():
    rows = ["| scenario | what it tests | contacts closing / passive | least clearance (m) | CBF viol. logged / exact | goal | path (m) | TV ω (rad/s per s) / Δω reversals | stalled (s) | states F/A/B/S/E/V/U |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for name, what in SCENARIOS:
        path = os.path.join(ROOT, "config", "scenarios", f"{name}.yaml")
        out = subprocess.run([OLDBF, "sim", path, "--json"], capture_output=True, text=True, check=True).stdout
        d = json.loads(out.strip().splitlines()[-1])
        s = d["steps_by_state"]
        goal = f"{d['time_to_goal_s']:.1f} s" if d["reached_goal"] else ("–" if d["time_to_goal_s"] is None and name == "dead_end" else "not reached")
        states = "/".join(str(s[k]) for k in ("forward", "avoid", "both_sides", "stop", "escape", "evade", "follow"))
        rows.append(f"| `{name}` | {what} | {d['closing_contacts']} / {d['passive_contacts']} | {d['min_clearance_m']:.3f} | "
                    f"{d['cbf_violations']} / {d['true_cbf_violations']} | {goal} | {d['path_length_m']:.2f} | "
                    f"{d['motion']['variation_omega_radps'] / max(d['motion']['duration_s'], 1e-9):.3f} / "
                    f"{100.0 * d['motion']['omega_reversals'] / max(d['steps'], 1):.2f} % | {d['stalled_s']:.1f} | {states} |")
    return "\n".join(rows)


def compare_table():
    rows = ["| scenario | " + " | ".join(CONTROLLERS) + " |", "|---|" + "---|" * len(CONTROLLERS)]
    for name, _ in SCENARIOS:
        text = open(os.path.join(RESULTS, f"scenario_{name}.txt")).read().splitlines()
        cells = {}
        for line in text[2:]:
            f = line.split()
            if len(f) < 4:
                continue
            key = {"oldbfpaper": "oldbf-paper"}.get(f[0], f[0])
            goal = f[3] if f[3] == "no" else f"{float(f[3]):.0f} s"
            cells[key] = f"{f[1]} / {float(f[2]):.2f} / {goal}".replace("-", "−")
        rows.append(f"| `{name}` | " + " | ".join(cells.get(c, "–") for c in CONTROLLERS) + " |")
    return "\n".join(rows)


def batch_table():
    rows = ["| template | controller | collision rate (worlds) | contacts closing / passive | least clearance median / p5 (m) | goal rate | TV ω (rad/s per s) / Δω reversals | stalled (s) |",
            "|---|---|---|---|---|---|---|---|"]
    for name, label in TEMPLATES:
        with open(os.path.join(RESULTS, f"batch_{name}.csv")) as f:
            by = {r["controller"]: r for r in csv.DictReader(f)}
        for i, c in enumerate(CONTROLLERS):
            r = by[c]
            goal = f"{100 * float(r['goal_rate_with_path']):.0f} %"
            if r["worlds_with_path"] != r["worlds"]:
                goal += f" ({r['worlds_reached_with_path']}/{r['worlds_with_path']} with a path)"
            cr = f"{100 * float(r['collision_rate']):.0f} % ({r['worlds_with_collision']})"
            if c == "oldbf":
                cr = f"**{cr}**"
            rows.append(f"| {label if i == 0 else ''} | {c} | {cr} | {r['closing_contacts_total']} / {r['passive_contacts_total']} | "
                        f"{float(r['min_clearance_median_m']):.3f} / {float(r['min_clearance_p5_m']):.3f} | {goal} | "
                        f"{float(r['mean_variation_omega_per_s']):.3f} / {100 * float(r['omega_reversal_rate']):.2f} % | "
                        f"{float(r['mean_stalled_s']):.1f} |".replace("-0.", "−0."))
    return "\n".join(rows)


def main():
    doc = open(DOC).read()
    for name, make in (("scenarios", scenarios_table), ("compare", compare_table), ("batch", batch_table)):
        pat = re.compile(rf"(<!-- table:{name} -->\n)(?:.*?\n)?(<!-- /table:{name} -->)", re.S)
        if not pat.search(doc):
            sys.exit(f"update_tables: no <!-- table:{name} --> markers in {DOC}")
        table = make()
        doc = pat.sub(lambda m: m.group(1) + table + "\n" + m.group(2), doc)
    open(DOC, "w").write(doc)
    print("update_tables: docs/RESULTS.md tables rewritten")


if __name__ == "__main__":
    main()
