#!/usr/bin/env python3
"""Target table of a bench_omicron CSV (markdown on stdout).

  /usr/bin/python3 bench/omicron/summary.py docs/results/omicron/omicron.csv

With several runs in the file, the first row of each case counts.
"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from plot import read_rows  # noqa: E402


def main():
    rows = [r for r in read_rows(sys.argv[1:]) if r["module"] == "omicron"]
    keys = sorted({(r["input"], r["points"]) for r in rows}, key=lambda k: (k[0] != "scene", k[0], k[1]))

    def one(inp, n, method, sweep="main"):
        sel = [r for r in rows if r["input"] == inp and r["points"] == n and r["method"] == method
               and r.get("p_sweep") == sweep]
        return sel[0] if sel else None

    print("| input | points | PCL load s | fread s | ours build s | build/load | first chunk s | first front s "
          "| front wait s | read passes s | peak B/pt over cloud | peak B/pt total | frame p50/p95/max ms "
          "| build+front s | topdown_10k s | pcl_octree s | outofcore s (out) | outofcore / (load+build) "
          "| outofcore / build | outofcore peak MB | ours peak MB total |")
    print("|" + "---|" * 21)
    for inp, n in keys:
        load, fr, ours, front = (one(inp, n, m) for m in ("pcl_load", "fread", "omicron", "omicron_front"))
        td, oc8, oc = one(inp, n, "topdown_10k"), one(inp, n, "pcl_octree"), one(inp, n, "pcl_outofcore")
        if not (load and ours):
            continue
        f = lambda v, p=3: f"{v:.{p}g}" if isinstance(v, float) else "–"  # noqa: E731
        frames = (f"{front['frame_p50_ms']:.3g} / {front['frame_p95_ms']:.3g} / {front['frame_max_ms']:.3g}"
                  if front and "frame_p50_ms" in front else "–")
        oc_s = oc["seconds"] if oc else None
        label = f"{int(n) // 1000000}M" if n >= 1e6 else f"{int(n)}"
        print(f"| {inp} | {label} | {f(load['seconds'])} | {f(fr['seconds']) if fr else '–'} | {f(ours['seconds'])} "
              f"| {f(ours['seconds'] / load['seconds'])} | {f(ours['first_chunk_s'])} | {f(ours['first_front_s'])} "
              f"| {f(ours['phase_front_wait_s'])} | {f(ours['read_s'])} | {f(ours['peak_delta_bpp'])} "
              f"| {f(ours['peak_total_bpp'])} | {frames} | {f(front['seconds']) if front else '–'} "
              f"| {f(td['seconds']) if td else '–'} | {f(oc8['seconds']) if oc8 else '–'} "
              f"| {f(oc_s) + ' (' + oc['p_out'] + ')' if oc else '–'} "
              f"| {f(oc_s / (load['seconds'] + ours['seconds'])) if oc else '–'} "
              f"| {f(oc_s / ours['seconds']) if oc else '–'} | {f(oc['peak_mb']) if oc else '–'} "
              f"| {f(ours['peak_total_bpp'] * n / 1048576)} |")
    disk = [r for r in rows if r["method"] == "pcl_outofcore_disk"]
    for r in disk:
        print(f"\npcl_outofcore_process writing to disk, {r['input']} {int(r['points']) // 1000000}M: "
              f"{r['seconds']:.3g} s, peak {r['peak_mb']:.0f} MB")


if __name__ == "__main__":
    main()
