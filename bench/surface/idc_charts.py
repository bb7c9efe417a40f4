#!/usr/bin/python3
"""Charts and a markdown table from bench_idc's CSV rows.

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
from matplotlib.ticker import FuncFormatter, MaxNLocator, NullFormatter  # noqa: E402


def plain_log(ax, axes="xy"):
    """Plain numbers on log axes; minor ticks are labelled too where an axis spans less than a decade."""
    fmt = FuncFormatter(lambda v, _: "%g" % float("%.3g" % v))
    for name in axes:
        axis, (lo, hi) = (ax.xaxis, ax.get_xlim()) if name == "x" else (ax.yaxis, ax.get_ylim())
        axis.set_major_formatter(fmt)
        axis.set_minor_formatter(fmt if hi < 10 * lo else NullFormatter())
        ax.tick_params(axis=name, which="minor", labelsize=7)


def load(path):
    rows = []
    with open(path) as f:
        for r in csv.reader(f):
            if not r or r[0] != "surface" or "sweep=" in r[2]:  # bench_rbf rows share surface.csv
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
    "idc": dict(color="tab:blue", marker="o", label="IDC, eps = 0 (one point per leaf)"),
    "idc_eps": dict(color="tab:cyan", marker="s", label="IDC eps sweep (one curve per leaf)"),
    "open3d_scalable_tsdf": dict(color="tab:red", marker="^", label="Open3D ScalableTSDF + MC (voxel sweep)"),
    "pcl_marching_cubes_hoppe": dict(color="tab:green", marker="v", label="PCL MarchingCubesHoppe (fused cloud)"),
    "pcl_greedy_projection": dict(color="tab:olive", marker="D", label="PCL GreedyProjection (fused cloud)"),
}


def mm(x):
    return "%g mm" % round(1e3 * x, 2)


def eps_leaves(rs):
    """The leaves at which IDC's eps was swept (rows with eps > 0)."""
    return sorted({detail(r) for r in rs if r["method"] == "idc" and r.get("p_eps", 0) > 0})


def eps_leaf(rs):
    """The finest leaf of IDC's eps sweep, or None."""
    leaves = eps_leaves(rs)
    return leaves[0] if leaves else None


def error_vs_triangles(rows, out):
    """Chamfer against triangles per input with truth: Open3D's voxel sweep and IDC's eps sweep as
    curves, IDC at each leaf (eps = 0) and PCL's peers as points."""
    inputs = [i for i in dict.fromkeys(r["input"] for r in rows) if any("chamfer" in r for r in rows if r["input"] == i)]
    if not inputs:
        return
    cols = min(3, len(inputs))
    nrows = (len(inputs) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(6.2 * cols, 4.4 * nrows + 0.5), squeeze=False)
    handles = {}
    for ax, inp in zip(axes.flat, inputs):
        rs = [r for r in rows if r["input"] == inp and "chamfer" in r and r["method"] != "idc_incremental"]
        curves = [("open3d_scalable_tsdf", sorted([r for r in rs if r["method"] == "open3d_scalable_tsdf"],
                                                  key=lambda r: -detail(r)))]
        for leaf in eps_leaves(rs):
            curves.append(("idc_eps", sorted([r for r in rs if r["method"] == "idc" and detail(r) == leaf],
                                             key=lambda r: -r.get("p_eps", 0))))
        points = {"idc": [r for r in rs if r["method"] == "idc" and r.get("p_eps", 0) == 0]}
        for m in ("pcl_marching_cubes_hoppe", "pcl_greedy_projection"):
            points[m] = [r for r in rs if r["method"] == m]
        for key, crs in curves:
            if len(crs) < 1:
                continue
            st = STYLE[key]
            (h,) = ax.plot([r["triangles"] for r in crs], [1e3 * r["chamfer"] for r in crs],
                           linestyle="-" if key == "open3d_scalable_tsdf" else "--", markersize=5, **st)
            handles[st["label"]] = h
            for r in crs:
                if key == "idc_eps" and r.get("p_eps", 0) == 0:
                    continue  # the sweep's start is IDC's point at this leaf, labelled there
                tag = ("eps %s" % mm(r["p_eps"])) if key == "idc_eps" else ("voxel %s" % mm(detail(r)))
                ax.annotate(tag, (r["triangles"], 1e3 * r["chamfer"]), fontsize=6.5, color=st["color"],
                            xytext=(4, -9 if key == "idc_eps" else 4), textcoords="offset points")
        for key, prs in points.items():
            if not prs:
                continue
            st = STYLE[key]
            h = ax.scatter([r["triangles"] for r in prs], [1e3 * r["chamfer"] for r in prs], s=42, zorder=3,
                           edgecolors="black", linewidths=0.6, color=st["color"], marker=st["marker"])
            handles[st["label"]] = h
            for r in prs:
                ax.annotate("leaf %s" % mm(detail(r)), (r["triangles"], 1e3 * r["chamfer"]), fontsize=6.5,
                            color=st["color"], xytext=(4, 4), textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.margins(x=0.15, y=0.12)
        plain_log(ax, "y")
        ax.set_xlabel("triangles")
        ax.set_ylabel("Chamfer distance to the seen truth (mm)")
        seen = [r["truth_seen_fraction"] for r in rs if "truth_seen_fraction" in r]
        ax.set_title(inp + (" (truth seen by the frames: %.0f %%)" % (100 * seen[0]) if seen else ""), fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[len(inputs):]:
        ax.set_visible(False)
    fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=min(3, len(handles)),
               fontsize=8, frameon=False)
    fig.suptitle("Chamfer (mean of accuracy and completion) against triangle count: model no more than a scene needs")
    fig.tight_layout(rect=(0, 0.5 / (4.4 * nrows + 0.5), 1, 1))
    fig.savefig(out + "/idc_error_vs_triangles.png", dpi=110)


ERROR_COLORS = {"chamfer": "tab:blue", "accuracy_mean": "tab:purple", "completion_mean": "tab:gray"}


def error_vs_eps(rows, out):
    inputs = [i for i in dict.fromkeys(r["input"] for r in rows)
              if any(r["method"] == "idc" and r.get("p_eps", 0) > 0 for r in rows if r["input"] == i)]
    if not inputs:
        return
    cols = min(3, len(inputs))
    nrows = (len(inputs) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(5.5 * cols, 4.2 * nrows + 0.6), squeeze=False)
    for ax in list(axes.flat)[len(inputs):]:
        ax.set_visible(False)
    handles = {}
    for ax, inp in zip(axes.flat, inputs):
        rs = [r for r in rows if r["input"] == inp and r["method"] == "idc"]
        leaf = eps_leaf(rs)
        if leaf is None:
            continue
        rs = sorted([r for r in rs if detail(r) == leaf], key=lambda r: r.get("p_eps", 0))
        xs = [max(r.get("p_eps", 0), 1e-5) for r in rs]
        for key, style, label in (("chamfer", "o-", "Chamfer"), ("accuracy_mean", "^:", "accuracy (output to truth)"),
                                  ("completion_mean", "v:", "completion (seen truth to output)")):
            if any(key in r for r in rs):
                (h,) = ax.plot(xs, [1e3 * r.get(key, float("nan")) for r in rs], style, color=ERROR_COLORS[key])
                handles[label + " (mm, left axis)"] = h
        ax.set_xscale("log")
        ax.set_xlabel("eps (m)")
        ax.set_ylabel("error (mm)")
        ax2 = ax.twinx()
        (h,) = ax2.plot(xs, [r["triangles"] for r in rs], "s--", color="tab:orange")
        handles["triangles (right axis)"] = h
        ax2.set_yscale("log")
        ax2.set_ylabel("triangles")
        ax.set_title("%s, leaf %g mm" % (inp, 1e3 * leaf), fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=len(handles), fontsize=8,
               frameon=False)
    fig.suptitle("IDC simplification (octree merges, then edge collapses) at the finest swept leaf: error and triangles against eps\n(the largest "
                 "distance of a merged vertex to the crossing planes it replaces; eps = 0 drawn at 1e-5)", fontsize=10)
    fig.tight_layout(rect=(0, 0.6 / (4.2 * nrows + 0.6), 1, 1))
    fig.savefig(out + "/idc_error_vs_eps.png", dpi=110)


def time_vs_detail(rows, out):
    inputs = [i for i in dict.fromkeys(r["input"] for r in rows)]
    fig, axes = plt.subplots(1, len(inputs), figsize=(4.6 * len(inputs), 4.5), squeeze=False)
    labels = {"idc": "IDC addFrame, eps = 0 (per leaf)", "open3d_scalable_tsdf": "Open3D Integrate (per voxel)"}
    handles = {}
    for ax, inp in zip(axes[0], inputs):
        for key in ("idc", "open3d_scalable_tsdf"):
            rs = sorted([r for r in rows if r["input"] == inp and r["method"] == key and r.get("p_eps", 0) == 0],
                        key=detail)
            if not rs:
                continue
            st = dict(STYLE[key], label=labels[key])
            xs = [1e3 * detail(r) for r in rs]
            (h,) = ax.plot(xs, [r["frame_ms_median"] for r in rs], "-", **st)
            handles[st["label"]] = h
            ax.fill_between(xs, [r["frame_ms_median"] for r in rs], [r["frame_ms_p95"] for r in rs],
                            color=st["color"], alpha=0.15)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.margins(x=0.1, y=0.1)
        plain_log(ax)
        ax.set_xlabel("leaf / voxel (mm)")
        ax.set_ylabel("ms per frame (median; band to p95)")
        ax.set_title(inp, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=len(handles), fontsize=8,
               frameon=False)
    fig.suptitle("Time per frame against detail (same run, shared 2-core machine)")
    fig.tight_layout(rect=(0, 0.06, 1, 1))
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
    cols = min(3, len(inputs))
    nrows = (len(inputs) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(5.5 * cols, 3.8 * nrows + 0.5), squeeze=False)
    colors = {"idc": "tab:blue", "idc_incremental": "tab:purple", "open3d_scalable_tsdf": "tab:red"}
    handles = {}
    for ax in list(axes.flat)[len(inputs):]:
        ax.set_visible(False)
    for ax, inp in zip(axes.flat, inputs):
        leaves = sorted({k[2] for k in data if k[0] == inp and k[1] == "idc_incremental"}) or \
            sorted({k[2] for k in data if k[0] == inp})
        leaf = leaves[0]
        for (i, m, l), pts in sorted(data.items()):
            if i != inp or l != leaf:
                continue
            pts.sort()
            label = {"idc": "IDC addFrame", "idc_incremental": "IDC addFrame + reconstruct",
                     "open3d_scalable_tsdf": "Open3D Integrate"}.get(m, m)
            (h,) = ax.plot([p[0] for p in pts], [p[1] for p in pts], "-", color=colors.get(m))
            handles[label] = h
        ax.set_xlabel("frame index")
        ax.set_ylabel("ms")
        ax.set_yscale("log")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        plain_log(ax, "y")
        ax.set_title("%s, %g mm" % (inp, 1e3 * leaf), fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=len(handles), fontsize=8,
               frameon=False)
    fig.suptitle("Time per frame against frame index (does the cost grow with the map?)")
    fig.tight_layout(rect=(0, 0.5 / (3.8 * nrows + 0.5), 1, 1))
    fig.savefig(out + "/idc_time_vs_frame.png", dpi=110)


def table(rows):
    cols = ["input", "method", "params", "frame_ms_median", "frame_ms_p95", "extract_ms", "triangles", "chamfer_mm",
            "hausdorff_mm", "accuracy_mm", "completion_mm", "memory_mib", "boundary_edges", "nonmanifold_edges"]
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
                "%.2f" % (1e3 * r["completion_mean"]) if "completion_mean" in r else "",
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
