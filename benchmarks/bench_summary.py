#!/usr/bin/env python3
"""Markdown tables of the raw outputs of scripts/bench.sh (docs/benchmarks.md).

    python3 benchmarks/bench_summary.py out/bench > out/bench/summary.md

Reads OUT/machine.txt, OUT/<benchmark>.json (Google Benchmark, with repetitions: the mean and
the standard deviation of the repetitions), OUT/navd/* and OUT/calib/*. Missing parts are
reported as missing, never invented.
"""
import csv
import json
import os
import re
import sys

BENCHMARKS = ["detect_benchmark", "identify_benchmark", "solve_benchmark", "frame_set_benchmark",
              "corner_refine_benchmark"]
UNIT_NS = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}


def fmt_time(ns):
    if ns >= 1e6:
        return f"{ns / 1e6:.3g} ms"
    if ns >= 1e3:
        return f"{ns / 1e3:.3g} us"
    return f"{ns:.3g} ns"


def fmt_counter(v):
    if abs(v) >= 1e4 or (v != 0 and abs(v) < 1e-2):
        return f"{v:.3g}"
    return f"{v:.3g}" if v != int(v) else str(int(v))


COUNTER_SKIP = {"items_per_second"}


def benchmark_table(path):
    with open(path) as f:
        data = json.load(f)
    rows = {}
    order = []
    for b in data.get("benchmarks", []):
        name = b.get("run_name", b["name"])
        agg = b.get("aggregate_name", "")
        if name not in rows:
            rows[name] = {}
            order.append(name)
        if b.get("run_type") == "aggregate":
            rows[name][agg] = b
        else:
            rows[name].setdefault("iteration", b)
    lines = ["| benchmark | wall (mean ± sd) | CPU (mean ± sd) | counters (mean) |", "|---|---|---|---|"]
    for name in order:
        r = rows[name]
        mean = r.get("mean", r.get("iteration"))
        sd = r.get("stddev")
        if mean is None:
            continue
        scale = UNIT_NS.get(mean.get("time_unit", "ns"), 1.0)
        wall = fmt_time(mean["real_time"] * scale)
        cpu = fmt_time(mean["cpu_time"] * scale)
        if sd is not None:
            wall += f" ± {fmt_time(sd['real_time'] * scale)}"
            cpu += f" ± {fmt_time(sd['cpu_time'] * scale)}"
        known = {"name", "run_name", "run_type", "repetitions", "repetition_index", "threads", "iterations",
                 "real_time", "cpu_time", "time_unit", "aggregate_name", "aggregate_unit", "family_index",
                 "per_family_instance_index", "error_occurred", "error_message"}
        counters = [f"{k}={fmt_counter(v)}" for k, v in mean.items()
                    if k not in known and k not in COUNTER_SKIP and isinstance(v, (int, float))]
        if mean.get("error_occurred"):
            counters.append("ERROR: " + mean.get("error_message", ""))
        lines.append(f"| {name} | {wall} | {cpu} | {', '.join(counters)} |")
    return lines


def time_v(path):
    out = {}
    if not os.path.exists(path):
        return out
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line.startswith("Maximum resident set size"):
                out["max_rss_kb"] = int(line.split(":")[-1])
            elif line.startswith("Elapsed (wall clock) time"):
                t = line.split(": ")[-1].split(":")
                out["wall_s"] = sum(float(x) * 60 ** i for i, x in enumerate(reversed(t)))
            elif line.startswith("User time"):
                out["user_s"] = float(line.split(":")[-1])
            elif line.startswith("System time"):
                out["sys_s"] = float(line.split(":")[-1])
            elif line.startswith("Exit status"):
                out["exit"] = int(line.split(":")[-1])
            elif line.startswith("Command being timed"):
                out["command"] = line.split(": ", 1)[-1].strip('"')
    return out


def malloc_calls(path):
    if not os.path.exists(path):
        return None
    m = re.search(r"malloc_calls=(\d+) bytes=(\d+)", open(path).read())
    return (int(m.group(1)), int(m.group(2))) if m else None


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "out/bench"
    print("## Machine\n")
    mt = os.path.join(out, "machine.txt")
    if os.path.exists(mt):
        print("```")
        print(open(mt).read().rstrip())
        print("```\n")
    for b in BENCHMARKS:
        p = os.path.join(out, b + ".json")
        print(f"## {b}\n")
        if os.path.exists(p):
            print("\n".join(benchmark_table(p)))
        else:
            print("(missing)")
        print()

    print("## mfns-navd (replay of a rendered paper-turntable sequence)\n")
    nav = os.path.join(out, "navd")
    t = time_v(os.path.join(nav, "time-v.txt"))
    if t:
        print(f"- peak RSS: {t.get('max_rss_kb', 0) / 1024:.1f} MiB ({t.get('max_rss_kb')} kB); wall {t.get('wall_s', 0):.2f} s, "
              f"user {t.get('user_s', 0):.2f} s, sys {t.get('sys_s', 0):.2f} s, exit {t.get('exit')}")
    else:
        print("- peak RSS: (missing)")
    poses = os.path.join(nav, "poses.csv")
    if os.path.exists(poses):
        with open(poses) as f:
            rows = list(csv.DictReader(f))
        counts = {}
        for r in rows:
            counts[r.get("status", "?")] = counts.get(r.get("status", "?"), 0) + 1
        print(f"- frame sets logged: {len(rows)}; status counts: {counts}")
    m10, m60 = malloc_calls(os.path.join(nav, "malloc-10.txt")), malloc_calls(os.path.join(nav, "malloc-60.txt"))
    if m10 and m60:
        print(f"- malloc-family calls of the whole process: {m10[0]} for 10 frame sets, {m60[0]} for 60; "
              f"difference per frame set after start: {(m60[0] - m10[0]) / 50:.2f} calls, {(m60[1] - m10[1]) / 50:.0f} bytes")
    else:
        print("- malloc count: (missing)")
    print()

    print("## Calibration (mfns-calib rig --method ml)\n")
    cal = os.path.join(out, "calib")
    d = time_v(os.path.join(cal, "dataset-time-v.txt"))
    c = time_v(os.path.join(cal, "time-v.txt"))
    if d:
        print(f"- dataset (mfns-sim calib-dataset): wall {d.get('wall_s', 0):.1f} s, exit {d.get('exit')}")
    runs = [("time-v.txt", "mfns-calib rig --method ml"),
            ("time-v-refined.txt", "mfns-calib rig --method ml --refine-corners")]
    found = False
    for name, label in runs:
        c = time_v(os.path.join(cal, name))
        if c:
            found = True
            print(f"- {label}: wall {c.get('wall_s', 0):.1f} s, user {c.get('user_s', 0):.1f} s, "
                  f"sys {c.get('sys_s', 0):.1f} s, peak RSS {c.get('max_rss_kb', 0) / 1024:.0f} MiB, exit {c.get('exit')}")
    if not d and not found:
        print("- (not run)")


if __name__ == "__main__":
    main()
