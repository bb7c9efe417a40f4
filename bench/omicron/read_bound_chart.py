"""Time against cloud size from the file: ours beside PCL's load and pcl_outofcore_process.

Usage: read_bound_chart.py NEW.csv OLD.csv OUT.png [RUN,RUN,...]
NEW.csv holds bench_omicron rows with a ";run=..." tag in params (omicron_read_bound.csv); the
scene rows of each run (or only of the listed runs) are drawn as points, the line goes through
their means. OLD.csv
(omicron.csv) gives the earlier first-front times from the file for comparison.
"""
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def rows(path):
    for line in open(path):
        f = line.rstrip("\n").split(",")
        if f[0] != "omicron" or len(f) < 6:
            continue
        m = dict(zip(f[6::2], f[7::2]))
        yield dict(method=f[1], params=f[2], input=f[3], points=float(f[4]), seconds=float(f[5]), **m)


def main(new_csv, old_csv, out_png, runs=None):
    wanted = set(runs.split(",")) if runs else None
    series = defaultdict(lambda: defaultdict(list))
    for r in rows(new_csv):
        p = r["params"]
        if "sweep=main" not in p or r["input"] != "scene":
            continue
        run = dict(kv.split("=", 1) for kv in p.split(";") if "=" in kv).get("run")
        if wanted and run not in wanted:
            continue
        n = r["points"]
        if r["method"] == "pcl_load":
            series["pcl::io::loadPCDFile"][n].append(r["seconds"])
        elif r["method"] == "pcl_outofcore":
            series["pcl_outofcore_process -gen_lod (tmpfs ≤ 20M, disk above)"][n].append(r["seconds"])
        elif r["method"] == "omicron" and "input=file" in p:
            series["ours: build from the file"][n].append(r["seconds"])
            series["ours: file → Potree folder"][n].append(float(r["file_to_potree_s"]))
        elif r["method"] == "omicron_front" and "input=file" in p:
            # The watched build (a thread evaluates the front): when it first has something to draw.
            series["ours: first renderable front"][n].append(float(r["first_front_s"]))
    for r in rows(old_csv):
        if (r["method"] == "omicron" and r["input"] == "scene" and "input=file" in r["params"]
                and "first_front_s" in r):
            series["ours before: first renderable front (earlier runs)"][r["points"]].append(float(r["first_front_s"]))
    style = {
        "pcl::io::loadPCDFile": dict(color="black", marker="s"),
        "pcl_outofcore_process -gen_lod (tmpfs ≤ 20M, disk above)": dict(color="tab:red", marker="v"),
        "ours: build from the file": dict(color="tab:blue", marker="o"),
        "ours: first renderable front": dict(color="tab:green", marker="^"),
        "ours: file → Potree folder": dict(color="tab:purple", marker="D"),
        "ours before: first renderable front (earlier runs)": dict(color="tab:green", marker="^", linestyle="--",
                                                                 alpha=0.5),
    }
    fig, ax = plt.subplots(figsize=(8, 5.5))
    for name, by_n in series.items():
        ns = sorted(by_n)
        st = style.get(name, {})
        for n in ns:
            ax.scatter([n] * len(by_n[n]), by_n[n], s=14, color=st.get("color"), alpha=st.get("alpha", 1.0))
        ax.plot(ns, [sum(by_n[n]) / len(by_n[n]) for n in ns], label=name, color=st.get("color"),
                marker=st.get("marker"), linestyle=st.get("linestyle", "-"), alpha=st.get("alpha", 1.0))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("points (scene PCD, warm page cache)")
    ax.set_ylabel("seconds")
    ax.set_title("OMiCroN from the file against PCL's load and out-of-core octree\n"
                 f"(2 cores, runs: {runs or 'all'}, peers in the same runs; line = mean)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_png, dpi=110)


if __name__ == "__main__":
    main(*sys.argv[1:5])
