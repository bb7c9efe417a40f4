#!/usr/bin/env python3
"""Turns pclx benchmark CSV into PNG charts.

  python3 bench/plot.py results/*.csv --out bench/results

Rows are `module,method,params,input,points,seconds,metric,value,...`. Each module
has chart specs below (time vs accuracy, accuracy vs degradation, ...); a module
without specs gets a generic seconds-vs-points chart.
"""
import argparse
import collections
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_rows(paths):
    rows = []
    for path in paths:
        with open(path, newline="") as f:
            for rec in csv.reader(f):
                if not rec or rec[0] == "module" or rec[0].startswith("#"):
                    continue
                if len(rec) < 6:
                    print(f"plot.py: skipping short row in {path}: {rec}", file=sys.stderr)
                    continue
                row = dict(module=rec[0], method=rec[1], params=rec[2], input=rec[3],
                           points=float(rec[4]), seconds=float(rec[5]))
                for k in range(6, len(rec) - 1, 2):
                    try:
                        row[rec[k]] = float(rec[k + 1])
                    except ValueError:
                        row[rec[k]] = rec[k + 1]
                for kv in filter(None, rec[2].split(";")):
                    if "=" in kv:
                        key, val = kv.split("=", 1)
                        try:
                            row.setdefault("p_" + key, float(val))
                        except ValueError:
                            row.setdefault("p_" + key, val)
                rows.append(row)
    return rows


# Chart specs per module. x / y name a column (or a metric, or p_<param>);
# `where` filters rows, `series` names the column that makes one line per value.
# Optional: kind="bars" (grouped bars, categorical x) or kind="stacked" (bars stacked from the
# metrics in `stack`); hlines=[(y, text)] reference lines on bar charts; xlabel / ylabel.
SPECS = {
    "scenes": [
        dict(name="scenes_time_vs_points", title="Ground truth throughput", x="points", y="seconds",
             series="method", logx=True, logy=True),
    ],
}


def load_module_specs():
    """bench/<module>/charts.py may define SPECS = [...] for that module."""
    import importlib.util
    here = os.path.dirname(os.path.abspath(__file__))
    for entry in sorted(os.listdir(here)):
        path = os.path.join(here, entry, "charts.py")
        if os.path.isfile(path):
            spec = importlib.util.spec_from_file_location(f"charts_{entry}", path)
            mod = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(mod)
            SPECS[entry] = mod.SPECS


def matches(row, where):
    for key, val in (where or {}).items():
        if str(row.get(key, row.get("p_" + key, ""))) != str(val):
            return False
    return True


def label(key, val):
    """Legend / tick text of a value: point counts as 20M, 500k."""
    if key == "points" or key == "p_points":
        n = int(val)
        if n % 1000000 == 0:
            return f"{n // 1000000}M"
        if n % 1000 == 0:
            return f"{n // 1000}k"
        return str(n)
    if isinstance(val, float) and val == int(val):
        return str(int(val))
    return str(val)


def bar_chart(rows, spec, out_dir):
    """kind="bars": grouped bars, one group per x value (categorical), one bar per series value.
    kind="stacked": one bar per x value, stacked from the metrics listed in spec["stack"]."""
    stacked = spec["kind"] == "stacked"
    ys = spec["stack"] if stacked else [spec["y"]]
    rows = [r for r in rows if matches(r, spec.get("where"))
            and r.get(spec["x"]) is not None and all(isinstance(r.get(y), float) for y in ys)]
    if not rows:
        return []
    split = spec.get("split") or []
    split = [split] if isinstance(split, str) else split
    groups = collections.OrderedDict()
    for r in sorted(rows, key=lambda r: tuple((r.get(k, 0) if k == "points" else str(r.get(k, ""))) for k in split)):
        groups.setdefault(", ".join(label(k, r.get(k, "")) for k in split), []).append(r)
    ncols = min(spec.get("cols", 3), len(groups))
    nrows = (len(groups) + ncols - 1) // ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.5 * ncols, 5 * nrows), squeeze=False)
    for ax in axes.flat[len(groups):]:
        ax.set_visible(False)
    for ax, (gname, grows) in zip(axes.flat, groups.items()):
        xvals = sorted({r[spec["x"]] for r in grows}, key=lambda v: (isinstance(v, str), v))
        if stacked:
            bottom = [0.0] * len(xvals)
            for y in ys:
                h = []
                for x in xvals:
                    sel = [r[y] for r in grows if r[spec["x"]] == x]
                    h.append(min(sel) if sel else 0.0)  # best of repeated rows
                ax.bar(range(len(xvals)), h, bottom=bottom, label=spec.get("stack_labels", {}).get(y, y))
                bottom = [b + v for b, v in zip(bottom, h)]
        else:
            series = collections.OrderedDict()
            for r in grows:
                series.setdefault(spec.get("series_fmt", "{}").format(label(spec["series"], r.get(spec["series"], ""))),
                                  []).append(r)
            order = spec.get("series_order")
            names = sorted(series, key=lambda s: order.index(s) if order and s in order else len(order or []))
            width = 0.8 / max(1, len(names))
            for i, sname in enumerate(names):
                xs, hs = [], []
                for j, x in enumerate(xvals):
                    sel = [r[spec["y"]] for r in series[sname] if r[spec["x"]] == x]
                    if sel:
                        xs.append(j - 0.4 + width * (i + 0.5))
                        hs.append(min(sel))
                bars = ax.bar(xs, hs, width=width, label=sname)
                if spec.get("annotate"):
                    ax.bar_label(bars, fmt=spec["annotate"], fontsize=6, rotation=90, padding=2)
        for yline, text in spec.get("hlines", []):
            ax.axhline(yline, color="k", linestyle="--", linewidth=1)
            ax.annotate(text, (0.01, yline), xycoords=("axes fraction", "data"), fontsize=7,
                        va="bottom")
        ax.set_xticks(range(len(xvals)))
        ax.set_xticklabels([label(spec["x"], x) for x in xvals])
        ax.set_xlabel(spec.get("xlabel", spec["x"].replace("p_", "")))
        ax.set_ylabel(spec.get("ylabel", spec.get("y", "seconds")))
        if spec.get("logy"):
            ax.set_yscale("log")
        ax.grid(True, axis="y", which="both", alpha=0.3)
        ax.set_title(f"{spec['title']}" + (f"\n{gname}" if gname else ""), fontsize=10)
        ax.legend(fontsize=7)
    fig.tight_layout()
    path = os.path.join(out_dir, spec["name"] + ".png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def chart(rows, spec, out_dir):
    if spec.get("kind") in ("bars", "stacked"):
        return bar_chart(rows, spec, out_dir)
    rows = [r for r in rows if matches(r, spec.get("where"))
            and isinstance(r.get(spec["x"]), float) and isinstance(r.get(spec["y"]), float)]
    if not rows:
        return []
    # `split` (a column or a list of columns) makes one panel per value, at most 3 per row.
    split = spec.get("split") or []
    split = [split] if isinstance(split, str) else split
    groups = collections.OrderedDict()
    for r in sorted(rows, key=lambda r: tuple(str(r.get(k, "")) for k in split)
                    if not any(k == "points" for k in split)
                    else tuple((r.get(k, 0) if k == "points" else str(r.get(k, ""))) for k in split)):
        key = ", ".join(f"{int(r[k])} pts" if k == "points" else str(r.get(k, "")) for k in split)
        groups.setdefault(key, []).append(r)
    ncols = min(3, len(groups))
    nrows = (len(groups) + ncols - 1) // ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.5 * ncols, 5 * nrows), squeeze=False)
    for ax in axes.flat[len(groups):]:
        ax.set_visible(False)
    for ax, (gname, grows) in zip(axes.flat, groups.items()):
        series = collections.OrderedDict()
        for r in grows:
            series.setdefault(str(r.get(spec["series"], "")), []).append(r)
        for sname, srows in series.items():
            srows.sort(key=lambda r: r[spec["x"]])
            xs = [r[spec["x"]] for r in srows]
            ys = [r[spec["y"]] for r in srows]
            if spec.get("scatter"):
                ax.scatter(xs, ys, label=sname, s=28)
            else:
                ax.plot(xs, ys, marker="o", label=sname)
        ax.set_xlabel(spec["x"].replace("p_", ""))
        ax.set_ylabel(spec["y"])
        if spec.get("logx"):
            ax.set_xscale("log")
        if spec.get("logy"):
            ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title(f"{spec['title']}" + (f"\n{gname}" if gname else ""), fontsize=10)
        ax.legend(fontsize=7)
    fig.tight_layout()
    path = os.path.join(out_dir, spec["name"] + ".png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv", nargs="+")
    ap.add_argument("--out", default="bench/results")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    load_module_specs()
    rows = read_rows(args.csv)
    if not rows:
        sys.exit("plot.py: no rows in " + " ".join(args.csv))
    written = []
    for module in sorted({r["module"] for r in rows}):
        mrows = [r for r in rows if r["module"] == module]
        specs = SPECS.get(module) or [dict(name=f"{module}_time_vs_points", title=module, x="points",
                                           y="seconds", series="method", logx=True, logy=True)]
        for spec in specs:
            written += chart(mrows, spec, args.out)
    for p in written:
        print("wrote", p)
    if not written:
        sys.exit("plot.py: no chart could be drawn from these rows")


if __name__ == "__main__":
    main()
