#!/usr/bin/env python3
"""The wide-set summary of `bench_hpr --wide` rows.

  /usr/bin/python3 bench/hpr/wide_summary.py docs/results/hpr/hpr.csv --note "load average 4-5 (two other helpers)"

One line per (shape, view, points): ours (pclx_auto, the default) F1 and seconds, the one-pass
candidate hull (the default before the refinement passes) from the same run, Open3D's
exact HPR at its best R (highest F1 over every open3d_exact row of the case, from any of the
given files), the speed-up, and MISSED where ours is < 50x faster or below F1 0.95.
Ratios are only meaningful within one run (the machine is shared). With --time cpu the
seconds are the process CPU time of each call (cpu_seconds, best of the repeats; written by
bench_hpr since this session), which a loaded machine inflates much less than wall time:
every call then runs on one thread, ours (setNumberOfThreads (0) picks one under load) and
Open3D's alike. With --time first our seconds are the first call of a fresh filter (it keeps
its working memory between calls, so the repeats reuse pages the first one faulted in).
"""
import argparse
import csv
import sys

TARGET_SPEEDUP = 50.0
TARGET_F1 = 0.95


def read(paths, time="wall"):
    rows = []
    for path in paths:
        with open(path, newline="") as f:
            for rec in csv.reader(f):
                if not rec or rec[0] != "hpr":
                    continue
                params = dict(kv.split("=", 1) for kv in rec[2].split(";") if "=" in kv)
                if params.get("sweep") != "wide":
                    continue
                row = dict(method=rec[1], params=params, input=rec[3], points=int(rec[4]), seconds=float(rec[5]))
                for k in range(6, len(rec) - 1, 2):
                    try:
                        row[rec[k]] = float(rec[k + 1])
                    except ValueError:
                        row[rec[k]] = rec[k + 1]
                row["wall_seconds"] = row["seconds"]
                if time == "cpu":
                    if "cpu_seconds" not in row:
                        continue
                    row["seconds"] = row["cpu_seconds"]
                if time == "first" and "first_call_seconds" in row:
                    row["seconds"] = row["first_call_seconds"]
                rows.append(row)
    # Open3D's best R per case is recomputed over every open3d_exact row of every file (a
    # supplementary run at other R merges in): the highest F1, the faster on a tie.
    rows = [r for r in rows if r["method"] != "open3d_exact_bestR"]
    best = {}
    for r in rows:
        if r["method"] == "open3d_exact":
            k = (r["input"], r["params"].get("view", "0"), r["points"])
            if k not in best or (r["f1"], -r["seconds"]) > (best[k]["f1"], -best[k]["seconds"]):
                best[k] = r
    rows += [dict(r, method="open3d_exact_bestR") for r in best.values()]
    return rows


def fmt_n(n):
    return f"{n // 1000000}M" if n % 1000000 == 0 else f"{n // 1000}k"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv", nargs="+")
    ap.add_argument("--out", help="write the markdown here (also printed)")
    ap.add_argument("--ours", default="pclx_auto", help="method row to compare (default: pclx_auto)")
    ap.add_argument("--note", default="", help="a line about the run (machine load, date)")
    ap.add_argument("--time", choices=["wall", "cpu", "first"], default="wall",
                    help="seconds compared (default: wall, best of the repeats); first: our rows' first call on a "
                         "fresh filter (wall, its working memory not yet allocated) against Open3D's best")
    ap.add_argument("--threads-table", action="store_true",
                    help="also a wall-time table: the default at 1 and 2 forced threads (pclx_auto_t1 / _t2 rows, "
                         "bench_hpr --wide-lean --dev-threads 1 2) against Open3D's wall time at its best R")
    args = ap.parse_args()
    rows = read(args.csv, args.time)
    if not rows:
        sys.exit("wide_summary.py: no sweep=wide rows")
    keys = []
    for r in rows:
        k = (r["input"], int(r["params"].get("view", 0)), r["points"])
        if k not in keys:
            keys.append(k)
    keys.sort(key=lambda k: (k[0], k[2], k[1]))
    lines = []
    if args.note:
        lines += [args.note, ""]
    lines += [
        f"| shape | view | n | ours F1 | ours P / R | ours s | Open3D best R | Open3D F1 | Open3D s | speed-up | "
        f"50x needs ours <= s | one pass F1 / speed-up | |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    missed = 0
    total = 0
    for shape, view, n in keys:
        sel = [r for r in rows if r["input"] == shape and int(r["params"].get("view", 0)) == view and r["points"] == n]
        ours = [r for r in sel if r["method"] == args.ours]
        o3d = [r for r in sel if r["method"] == "open3d_exact_bestR"]
        if not ours:
            continue
        o = ours[-1]
        one = [r for r in sel if r["method"] == "pclx_candidate_hull_1pass"]
        total += 1
        if o3d:
            b = o3d[-1]
            speed = b["seconds"] / o["seconds"]
            o3d_cells = (f"{b['params'].get('R', '?')} | {b['f1']:.3f} | {b['seconds']:.3g} | {speed:.1f}x | "
                         f"{b['seconds'] / TARGET_SPEEDUP:.3g}")
        else:
            speed = None
            o3d_cells = "- | - | - | - | -"
        bad = o["f1"] < TARGET_F1 or (speed is not None and speed < TARGET_SPEEDUP)
        why = []
        if o["f1"] < TARGET_F1:
            why.append(f"F1 < {TARGET_F1}")
        if speed is not None and speed < TARGET_SPEEDUP:
            why.append(f"< {TARGET_SPEEDUP:.0f}x")
        missed += bad
        one_cell = "-"
        if one:
            one_cell = f"{one[-1]['f1']:.3f}"
            if o3d:
                one_cell += f" / {o3d[-1]['seconds'] / one[-1]['seconds']:.1f}x"
        lines.append(f"| {shape} | {view} | {fmt_n(n)} | {o['f1']:.3f} | {o['precision']:.3f} / {o['recall']:.3f} | "
                     f"{o['seconds']:.3g} | {o3d_cells} | {one_cell} | "
                     f"{'MISSED (' + ', '.join(why) + ')' if bad else 'ok'} |")
    lines += ["", f"{total - missed} of {total} cases meet >= {TARGET_SPEEDUP:.0f}x Open3D (best R) at F1 >= {TARGET_F1}."]
    # Per size: how many views reach each half of the target.
    for n in sorted({k[2] for k in keys}):
        sel = [k for k in keys if k[2] == n]
        f1_ok = speed_ok = 0
        for shape, view, _ in sel:
            o = [r for r in rows if r["method"] == args.ours and r["input"] == shape and
                 int(r["params"].get("view", 0)) == view and r["points"] == n]
            b = [r for r in rows if r["method"] == "open3d_exact_bestR" and r["input"] == shape and
                 int(r["params"].get("view", 0)) == view and r["points"] == n]
            if o:
                f1_ok += o[-1]["f1"] >= TARGET_F1
                speed_ok += bool(b) and b[-1]["seconds"] / o[-1]["seconds"] >= TARGET_SPEEDUP
        lines.append(f"- {fmt_n(n)}: F1 >= {TARGET_F1} on {f1_ok} of {len(sel)} views, >= {TARGET_SPEEDUP:.0f}x on "
                     f"{speed_ok} of {len(sel)}.")
    if args.threads_table:
        lines += ["", "Wall time (seconds column of the CSVs; Open3D at the R of the table above), the default at forced "
                  "thread counts and at the automatic count:", "",
                  "| shape | view | n | Open3D wall s | ours 1 thread s | ours 2 threads s | ours auto s (threads) | "
                  "speed-up 1 / 2 threads / auto | 2 threads vs 1 |", "|---|---|---|---|---|---|---|---|---|"]
        for shape, view, n in keys:
            sel = [r for r in rows if r["input"] == shape and int(r["params"].get("view", 0)) == view and
                   r["points"] == n]
            get = lambda m: ([r for r in sel if r["method"] == m] or [None])[-1]  # noqa: E731
            b, t1, t2, a = get("open3d_exact_bestR"), get("pclx_auto_t1"), get("pclx_auto_t2"), get("pclx_auto")
            if not (b and t1 and t2 and a):
                continue
            w = lambda r: r["wall_seconds"]  # noqa: E731
            lines.append(f"| {shape} | {view} | {fmt_n(n)} | {w(b):.3g} | {w(t1):.3g} | {w(t2):.3g} | "
                         f"{w(a):.3g} ({int(a.get('threads_used', 0))}) | {w(b) / w(t1):.1f}x / {w(b) / w(t2):.1f}x / "
                         f"{w(b) / w(a):.1f}x | {w(t2) / w(t1):.2f} |")
    text = "\n".join(lines) + "\n"
    print(text, end="")
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
