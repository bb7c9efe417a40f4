#!/usr/bin/python3
"""Charts and a markdown table from bench_idc's CSV rows (issue 10).

usage: idc_charts.py RESULTS.csv FRAMES.csv OUTDIR
  RESULTS.csv  bench_idc --csv (module,method,params,input,frames,seconds,metric,value,...)
  FRAMES.csv   bench_idc --frames-csv (input,method,leaf,frame,ms)
Writes OUTDIR/idc_error_vs_triangles.png, idc_error_vs_eps.png, idc_time_vs_detail.png,
idc_time_vs_frame.png and prints a markdown table of every row.
"""
import csv
import sys
from collections import defaultdict

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import ScalarFormatter  # noqa: E402


def plain(ax):
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(ScalarFormatter())
        axis.get_major_formatter().set_scientific(False)


def load(path):
    rows = []
    with open(path) as f:
        for r in csv.reader(f):
            if not r or r[0] != "surface":
                continue
            d = dict(method=r[1], input=r[3], frames=int(r[4]), seconds=float(r[5]))
            for kv in r[2].split(";"):
                if "=" in kv:
                    k, v = kv.split("=", 1)
                    try:
                        d["p_" + k] = float(v)
                    except ValueError:
                        d["p_" + k] = v
            for i in range(6, len(r) - 1, 2):
                d[r[i]] = float(r[i + 1])
            rows.append(d)
    return rows


def detail(d):
    return d.get("p_leaf", d.get("p_voxel"))


STYLE = {
    "idc": dict(color="tab:blue", marker="o", label="IDC (leaf sweep, eps = 0)"),
    "idc_eps": dict(color="tab:cyan", marker="s", label="IDC (eps sweep, middle leaf)"),
    "open3d_scalable_tsdf": dict(color="tab:red", marker="^", label="Open3D ScalableTSDF + MC"),
    "pcl_marching_cubes_hoppe": dict(color="tab:green", marker="v", label="PCL MarchingCubesHoppe (fused cloud)"),
    "pcl_greedy_projection": dict(color="tab:olive", marker="D", label="PCL GreedyProjection (fused cloud)"),
}


def series_of(d):
    if d["method"] == "idc":
        return "idc_eps" if d.get("p_eps", 0) > 0 else "idc"
    return d["method"]


def error_vs_triangles(rows, out):
    inputs = [i for i in dict.fromkeys(r["input"] for r in rows) if any("chamfer" in r for r in rows if r["input"] == i)]
    if not inputs:
        return
    fig, axes = plt.subplots(1, len(inputs), figsize=(6 * len(inputs), 4.8), squeeze=False)
    for ax, inp in zip(axes[0], inputs):
        groups = defaultdict(list)
        for r in rows:
            if r["input"] == inp and "chamfer" in r and r["method"] != "idc_incremental":
                groups[series_of(r)].append(r)
        eps_zero_mid = None
        for key, rs in groups.items():
            st = STYLE.get(key, dict(label=key))
            rs = sorted(rs, key=lambda r: r["triangles"])
            ax.plot([r["triangles"] for r in rs], [1e3 * r["chamfer"] for r in rs], linestyle="-" if key != "idc_eps" else "--",
                    **st)
            for r in rs:
                tag = ("eps %g mm" % (1e3 * r["p_eps"])) if key == "idc_eps" else ("%g mm" % (1e3 * detail(r)))
                ax.annotate(tag, (r["triangles"], 1e3 * r["chamfer"]), fontsize=7, xytext=(3, 3), textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(ScalarFormatter())
        ax.set_xlabel("triangles")
        ax.set_ylabel("Chamfer distance to the truth (mm)")
        ax.set_title(inp)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Error against triangle count: model no more than a scene needs")
    fig.tight_layout()
    fig.savefig(out + "/idc_error_vs_triangles.png", dpi=110)


def error_vs_eps(rows, out):
    inputs = [i for i in dict.fromkeys(r["input"] for r in rows)
              if any(r["method"] == "idc" and r.get("p_eps", 0) > 0 for r in rows if r["input"] == i)]
    if not inputs:
        return
    fig, axes = plt.subplots(1, len(inputs), figsize=(5 * len(inputs), 4.2), squeeze=False)
    for ax, inp in zip(axes[0], inputs):
        rs = [r for r in rows if r["input"] == inp and r["method"] == "idc"]
        leaves = sorted({detail(r) for r in rs if r.get("p_eps", 0) > 0})
        if not leaves:
            continue
        leaf = leaves[0]
        rs = sorted([r for r in rs if detail(r) == leaf], key=lambda r: r.get("p_eps", 0))
        xs = [max(r.get("p_eps", 0), 1e-5) for r in rs]
        key = "chamfer" if "chamfer" in rs[0] else "accuracy_mean"
        ax.plot(xs, [1e3 * r.get(key, float("nan")) for r in rs], "o-", color="tab:blue",
                label=("Chamfer" if key == "chamfer" else "accuracy (output to truth)") + " (mm)")
        ax.set_xscale("log")
        ax.set_xlabel("eps (m, RMS plane distance of a merged cell; eps = 0 drawn at 1e-5)")
        ax.set_ylabel("error (mm)")
        ax2 = ax.twinx()
        ax2.plot(xs, [r["triangles"] for r in rs], "s--", color="tab:orange", label="triangles")
        ax2.set_yscale("log")
        ax2.set_ylabel("triangles")
        ax.set_title("%s, leaf %g mm" % (inp, 1e3 * leaf))
        ax.grid(True, which="both", alpha=0.3)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="upper left")
    fig.suptitle("IDC octree simplification: error and triangles against eps")
    fig.tight_layout()
    fig.savefig(out + "/idc_error_vs_eps.png", dpi=110)


def time_vs_detail(rows, out):
    inputs = [i for i in dict.fromkeys(r["input"] for r in rows)]
    fig, axes = plt.subplots(1, len(inputs), figsize=(4.6 * len(inputs), 4.2), squeeze=False)
    for ax, inp in zip(axes[0], inputs):
        for key in ("idc", "open3d_scalable_tsdf"):
            rs = sorted([r for r in rows if r["input"] == inp and r["method"] == key and r.get("p_eps", 0) == 0],
                        key=detail)
            if not rs:
                continue
            st = STYLE[key]
            xs = [1e3 * detail(r) for r in rs]
            ax.plot(xs, [r["frame_ms_median"] for r in rs], "-", **st)
            ax.fill_between(xs, [r["frame_ms_median"] for r in rs], [r["frame_ms_p95"] for r in rs],
                            color=st["color"], alpha=0.15)
        ax.set_xscale("log")
        ax.set_yscale("log")
        plain(ax)
        ax.set_xlabel("leaf / voxel (mm)")
        ax.set_ylabel("ms per frame (median; band to p95)")
        ax.set_title(inp)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Time per frame against detail (same run, shared 2-core machine)")
    fig.tight_layout()
    fig.savefig(out + "/idc_time_vs_detail.png", dpi=110)


def time_vs_frame(path, out):
    data = defaultdict(list)
    with open(path) as f:
        for r in csv.DictReader(f):
            if not r.get("ms"):
                continue  # a partly written file
            data[(r["input"], r["method"], float(r["leaf"]))].append((int(r["frame"]), float(r["ms"])))
    inputs = [i for i in dict.fromkeys(k[0] for k in data)]
    if not inputs:
        return
    fig, axes = plt.subplots(1, len(inputs), figsize=(5 * len(inputs), 4.2), squeeze=False)
    colors = {"idc": "tab:blue", "idc_incremental": "tab:purple", "open3d_scalable_tsdf": "tab:red"}
    for ax, inp in zip(axes[0], inputs):
        leaves = sorted({k[2] for k in data if k[0] == inp and k[1] == "idc_incremental"}) or \
            sorted({k[2] for k in data if k[0] == inp})
        leaf = leaves[0]
        for (i, m, l), pts in sorted(data.items()):
            if i != inp or l != leaf:
                continue
            pts.sort()
            label = {"idc": "IDC addFrame", "idc_incremental": "IDC addFrame + reconstruct",
                     "open3d_scalable_tsdf": "Open3D Integrate"}.get(m, m)
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "-", color=colors.get(m), label=label)
        ax.set_xlabel("frame index")
        ax.set_ylabel("ms")
        ax.set_yscale("log")
        ax.set_title("%s, %g mm" % (inp, 1e3 * leaf))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Time per frame against frame index (does the cost grow with the map?)")
    fig.tight_layout()
    fig.savefig(out + "/idc_time_vs_frame.png", dpi=110)


def table(rows):
    cols = ["input", "method", "params", "frame_ms_median", "frame_ms_p95", "extract_ms", "triangles", "chamfer_mm",
            "hausdorff_mm", "accuracy_mm", "memory_mib", "boundary_edges", "nonmanifold_edges"]
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for r in rows:
        params = ";".join("%s=%g" % (k[2:], v) for k, v in r.items() if k.startswith("p_") and isinstance(v, float)
                          and k[2:] in ("leaf", "voxel", "eps"))
        vals = [r["input"], r["method"], params, "%.1f" % r["frame_ms_median"], "%.1f" % r["frame_ms_p95"],
                "%.0f" % r.get("extract_ms", 0), "%d" % r["triangles"],
                "%.2f" % (1e3 * r["chamfer"]) if "chamfer" in r else "",
                "%.1f" % (1e3 * r["hausdorff"]) if "hausdorff" in r else "",
                "%.2f" % (1e3 * r["accuracy_mean"]) if "accuracy_mean" in r else "",
                "%.1f" % r["memory_mib"], "%d" % r["boundary_edges"], "%d" % r["nonmanifold_edges"]]
        print("| " + " | ".join(vals) + " |")


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    rows = load(sys.argv[1])
    out = sys.argv[3]
    error_vs_triangles(rows, out)
    error_vs_eps(rows, out)
    time_vs_detail(rows, out)
    time_vs_frame(sys.argv[2], out)
    table(rows)


if __name__ == "__main__":
    main()
