#!/usr/bin/env python3
"""Pooled batch figures over many seeds (the tables of docs/RESULTS.md).

    docs/eval_seeds.py run OUT [--templates a,b] [--seeds 1-14] [--controllers oldbf] [--exe BIN]
    docs/eval_seeds.py table OUT [--seeds 1-7] [--controller oldbf] [--against OUT2]
    docs/eval_seeds.py paired BEFORE AFTER [--seeds 8-14] [--controller oldbf]

`run` calls `oldbf batch TEMPLATE --worlds 100 --seed S --json` for every
template and seed and keeps each JSON in OUT/<template>_<seed>.json (a file
already there is kept: a run can be resumed). `table` pools the seeds given
(worlds, contacts, goals and steps summed; per-world means averaged over
worlds) and prints one Markdown row per template; with --against, the
figures of OUT2 (before) and OUT (after) side by side as `before → after`.

`run` also keeps each batch's per-world rows as OUT/<template>_<seed>.csv.
`paired` compares two runs world by world (the same worlds: a world depends
only on the template, the seed and its index): per template, the worlds
where only one of the two had a contact, lost or won a goal, or met the
time budget, with the two-sided exact sign test's p on those discordant
worlds, and the mean change of the time to the goal over the worlds both
reached (± its standard error). Pooled rates of 140 worlds move by about 4
points under any change that moves a path; the discordant worlds say
whether a change did more than that.
"""
import argparse
import csv
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

TEMPLATES = ["static_clutter", "doorways", "slow_obstacles", "fast_obstacles", "movers_crossing",
             "movers_head_on", "movers_overtaking", "mixed", "rooms", "doorways_tilted"]
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def seeds_of(text):
    out = []
    for part in text.split(","):
        if "-" in part:
            a, b = part.split("-")
            out.extend(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def run(args):
    os.makedirs(args.out, exist_ok=True)
    exe = args.exe or os.path.join(ROOT, "target", "release", "oldbf")
    for t in args.templates.split(","):
        for s in seeds_of(args.seeds):
            path = os.path.join(args.out, f"{t}_{s}.json")
            if os.path.exists(path):
                continue
            with tempfile.TemporaryDirectory(prefix="eval_seeds_") as rows:
                cmd = [exe, "batch", os.path.join(ROOT, "config", "batch", f"{t}.yaml"), "--worlds",
                       str(args.worlds), "--seed", str(s), "--controllers", args.controllers, "--json",
                       "--out", rows] + args.extra.split()
                res = subprocess.run(cmd, capture_output=True, text=True, check=True)
                line = res.stdout.strip().splitlines()[-1]
                shutil.move(os.path.join(rows, "per_world.csv"), os.path.join(args.out, f"{t}_{s}.csv"))
            with open(path + ".tmp", "w") as f:
                f.write(line)
            os.replace(path + ".tmp", path)
            print(f"{t} seed {s} done", file=sys.stderr)


def pool(out, template, seeds, controller):
    acc = None
    for s in seeds:
        path = os.path.join(out, f"{template}_{s}.json")
        if not os.path.exists(path):
            return None
        with open(path) as f:
            rows = [r for r in json.load(f)["rows"] if r["controller"] == controller]
        if not rows:
            return None
        r = rows[0]
        if acc is None:
            acc = {k: 0.0 for k in ("worlds", "contact_worlds", "closing", "passive", "reached", "with_path", "in_budget",
                                    "tv_v", "tv_w", "tv_w_up", "rev_w", "rev_v", "steps", "window", "switch_min",
                                    "above", "rev_escape", "rev_evade", "rev_other", "sign", "moving", "evade",
                                    "clear_med", "p99", "max_us", "infeasible", "cbf_feasible", "brake_feasible")}
        w, n = r["worlds"], r["steps_total"]
        acc["worlds"] += w
        acc["contact_worlds"] += r["worlds_with_collision"]
        acc["closing"] += r["closing_contacts_total"]
        acc["passive"] += r["passive_contacts_total"]
        acc["reached"] += r["worlds_reached_with_path"]
        acc["with_path"] += r["worlds_with_path"]
        # Only templates with time_budget_factor have it (None otherwise, absent in older JSON).
        if r.get("worlds_within_budget_with_path") is not None:
            acc["in_budget"] += r["worlds_within_budget_with_path"]
            acc["has_budget"] = True
        acc["tv_v"] += r["mean_variation_v_per_s"] * w
        acc["tv_w"] += r["mean_variation_omega_per_s"] * w
        # The upstream command's own variation (absent in older JSON).
        if r.get("mean_upstream_variation_omega_per_s") is not None:
            acc["tv_w_up"] += r["mean_upstream_variation_omega_per_s"] * w
            acc["up_worlds"] = acc.get("up_worlds", 0) + w
        acc["rev_w"] += r["omega_reversal_rate"] * n
        acc["rev_v"] += r["v_reversal_rate"] * n
        acc["steps"] += n
        acc["window"] += r["window_exceeded_total"]
        acc["switch_min"] += r["state_switches_per_min"] * n
        acc["above"] += r["above_upstream_steps_total"]
        if r.get("above_upstream_escape_steps_total") is not None:
            acc["above_esc"] = acc.get("above_esc", 0) + r["above_upstream_escape_steps_total"]
            acc["above_esc_worlds"] = acc.get("above_esc_worlds", 0) + w
        acc["rev_escape"] += r["reverse_escape_steps_total"]
        acc["rev_evade"] += r["reverse_evade_steps_total"]
        acc["rev_other"] += r["reverse_other_steps_total"]
        acc["sign"] += r["v_sign_changes_total"]
        acc["moving"] += r["moving_track_step_rate"] * n
        acc["evade"] += r["evade_steps_total"]
        acc["clear_med"] += r["min_clearance_median_m"] * w
        acc["p99"] = max(acc["p99"], r["p99_step_us"])
        acc["max_us"] = max(acc["max_us"], r["max_step_us"])
        acc["infeasible"] += r["infeasible_steps_total"]
        acc["cbf_feasible"] += r["cbf_violations_feasible_total"]
        acc["brake_feasible"] += r["braking_violations_feasible_total"]
    w, n = acc["worlds"], acc["steps"]
    return {
        "worlds": int(w),
        "contact worlds": int(acc["contact_worlds"]),
        "closing / passive": f"{int(acc['closing'])} / {int(acc['passive'])}",
        "goal rate": f"{100 * acc['reached'] / max(acc['with_path'], 1):.1f} %",
        "goal in budget": (f"{100 * acc['in_budget'] / max(acc['with_path'], 1):.1f} %"
                           if acc.get("has_budget") else "–"),
        "TV v": f"{acc['tv_v'] / w:.3f}",
        "TV ω": f"{acc['tv_w'] / w:.3f}",
        "upstream's TV ω": (f"{acc['tv_w_up'] / acc['up_worlds']:.3f}" if acc.get("up_worlds") == w else "–"),
        "rev Δv": f"{100 * acc['rev_v'] / n:.2f} %",
        "rev Δω": f"{100 * acc['rev_w'] / n:.2f} %",
        "outside window": int(acc["window"]),
        "switches/min": f"{acc['switch_min'] / n:.1f}",
        "above upstream": (f"{int(acc['above'])} (esc {int(acc['above_esc'])})"
                           if acc.get("above_esc_worlds") == w else f"{int(acc['above'])}"),
        "reverse unasked (esc/eva/other)": f"{int(acc['rev_escape'])}/{int(acc['rev_evade'])}/{int(acc['rev_other'])}",
        "v sign changes": int(acc["sign"]),
        "moving track": f"{100 * acc['moving'] / n:.1f} %",
        "evade": int(acc["evade"]),
        "median least clearance": f"{acc['clear_med'] / w:.3f}",
        "CBF / braking viol. (feasible)": f"{int(acc['cbf_feasible'])} / {int(acc['brake_feasible'])}",
        "p99 / max step (µs)": f"{acc['p99']:.0f} / {acc['max_us']:.0f}",
    }


def table(args):
    seeds = seeds_of(args.seeds)
    header = None
    for t in args.templates.split(","):
        after = pool(args.out, t, seeds, args.controller)
        if after is None:
            continue
        before = pool(args.against, t, seeds, args.controller) if args.against else None
        if header is None:
            header = list(after.keys())
            print("| template | " + " | ".join(header) + " |")
            print("|---" * (len(header) + 1) + "|")
        cells = []
        for k in header:
            if before is not None and str(before[k]) != str(after[k]):
                cells.append(f"{before[k]} → {after[k]}")
            else:
                cells.append(str(after[k]))
        print(f"| {t} | " + " | ".join(cells) + " |")


def sign_test_p(a, b):
    """Two-sided exact sign test: the chance of a split of the a + b
    discordant worlds at least as uneven as (a, b) if either way were as likely."""
    n = a + b
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(min(a, b) + 1)) / 2 ** n
    return min(1.0, 2 * tail)


def per_world(out, template, seeds, controller):
    rows = {}
    for s in seeds:
        path = os.path.join(out, f"{template}_{s}.csv")
        if not os.path.exists(path):
            return None
        with open(path) as f:
            for r in csv.DictReader(f):
                if r["controller"] == controller:
                    rows[(s, int(r["world"]))] = r
    return rows


def paired(args):
    seeds = seeds_of(args.seeds)
    print("| template | worlds | contact worlds (only before / only after, p) | closing contacts | "
          "goal rate (lost / won, p) | goal in budget (lost / won, p) | time to goal, both reached (s) |")
    print("|---|---|---|---|---|---|---|")
    for t in args.templates.split(","):
        a = per_world(args.before, t, seeds, args.controller)
        b = per_world(args.after, t, seeds, args.controller)
        if not a or not b:
            continue
        keys = sorted(set(a) & set(b))

        def split(flag, among):
            only_a = sum(flag(a[k]) and not flag(b[k]) for k in among)
            only_b = sum(flag(b[k]) and not flag(a[k]) for k in among)
            return sum(flag(a[k]) for k in among), sum(flag(b[k]) for k in among), only_a, only_b

        def cell(flag, among, rate):
            na, nb, oa, ob = split(flag, among)
            if rate:
                na, nb = f"{100 * na / len(among):.1f} %", f"{100 * nb / len(among):.1f} %"
            return f"{na} → {nb} ({oa} / {ob}, p {sign_test_p(oa, ob):.2f})"

        contact = cell(lambda r: int(r["collisions"]) > 0, keys, False)
        closing = f"{sum(int(a[k]['closing_contacts']) for k in keys)} → {sum(int(b[k]['closing_contacts']) for k in keys)}"
        with_path = [k for k in keys if a[k]["path_exists"] == "true"]
        goal = cell(lambda r: r["reached_goal"] == "true", with_path, True) if with_path else "–"
        budgeted = [k for k in with_path if a[k]["goal_within_budget"] != ""]
        budget = cell(lambda r: r["goal_within_budget"] == "true", budgeted, True) if budgeted else "–"
        dt = [float(b[k]["time_to_goal_s"]) - float(a[k]["time_to_goal_s"]) for k in with_path
              if a[k]["reached_goal"] == "true" and b[k]["reached_goal"] == "true"]
        time = (f"{statistics.mean(dt):+.2f} ± {statistics.stdev(dt) / math.sqrt(len(dt)):.2f}"
                if len(dt) > 1 else "–")
        print(f"| {t} | {len(keys)} | {contact} | {closing} | {goal} | {budget} | {time} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("out")
    r.add_argument("--templates", default=",".join(TEMPLATES))
    r.add_argument("--seeds", default="1-14")
    r.add_argument("--worlds", type=int, default=100)
    r.add_argument("--controllers", default="oldbf")
    r.add_argument("--exe", help="the oldbf binary (default: target/release/oldbf)")
    r.add_argument("--extra", default="", help="more options for `oldbf batch`, e.g. --config FILE")
    t = sub.add_parser("table")
    t.add_argument("out")
    t.add_argument("--templates", default=",".join(TEMPLATES))
    t.add_argument("--seeds", default="1-14")
    t.add_argument("--controller", default="oldbf")
    t.add_argument("--against")
    pr = sub.add_parser("paired")
    pr.add_argument("before")
    pr.add_argument("after")
    pr.add_argument("--templates", default=",".join(TEMPLATES))
    pr.add_argument("--seeds", default="1-14")
    pr.add_argument("--controller", default="oldbf")
    a = ap.parse_args()
    {"run": run, "table": table, "paired": paired}[a.cmd](a)


if __name__ == "__main__":
    main()
