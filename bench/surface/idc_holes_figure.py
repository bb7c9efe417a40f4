#!/usr/bin/env python3
"""Open edges of IDC meshes with and without hole closing, side by side.

Usage: idc_holes_figure.py OUT.png TITLE (LABEL MESH.ply)...
The meshes come from `bench_idc --mesh-dir DIR` (and `--hole-leaves 0` for the open ones). Open
edges (used by one triangle) are drawn in red over the surface, so holes behind it show too.
"""
import sys
from collections import Counter

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection


def load_ply(path):
    """Vertices and triangles of a binary little-endian PLY as pcl::io writes it."""
    with open(path, "rb") as f:
        header, props, element = [], [], None
        while True:
            line = f.readline().decode().strip()
            header.append(line)
            words = line.split()
            if words[0] == "element":
                element, count = words[1], int(words[2])
                if element == "vertex":
                    nv = count
                elif element == "face":
                    nf = count
            elif words[0] == "property" and element == "vertex":
                props.append(words[1])
            elif words[0] == "end_header":
                break
        types = {"float": "<f4", "double": "<f8", "uchar": "u1", "int": "<i4", "uint": "<u4"}
        vtype = np.dtype([("p%d" % i, types[t]) for i, t in enumerate(props)])
        v = np.frombuffer(f.read(nv * vtype.itemsize), vtype)
        ftype = np.dtype([("n", "u1"), ("i", "<i4", 3)])
        faces = np.frombuffer(f.read(nf * ftype.itemsize), ftype)["i"].astype(int)
    return np.stack([v["p0"], v["p1"], v["p2"]], 1).astype(float), faces


def open_edges(faces):
    count = Counter()
    for a, b, c in faces:
        for u, w in ((a, b), (b, c), (c, a)):
            count[(min(u, w), max(u, w))] += 1
    return np.array([e for e, k in count.items() if k == 1], dtype=int).reshape(-1, 2)


def main():
    out, title, pairs = sys.argv[1], sys.argv[2], list(zip(sys.argv[3::2], sys.argv[4::2]))
    cols = 2
    rows = (len(pairs) + cols - 1) // cols
    fig = plt.figure(figsize=(6 * cols, 5.5 * rows))
    elev, azim = 12, 90
    light = np.array([np.cos(np.radians(elev)) * np.cos(np.radians(azim)),
                      np.cos(np.radians(elev)) * np.sin(np.radians(azim)), np.sin(np.radians(elev))])
    for i, (label, path) in enumerate(pairs):
        v, f = load_ply(path)
        edges = open_edges(f)
        ax = fig.add_subplot(rows, cols, i + 1, projection="3d", computed_zorder=False)
        tri = v[f]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.linalg.norm(n, axis=1)[:, None] + 1e-12
        shade = 0.25 + 0.7 * np.abs(n @ light)
        ax.add_collection3d(Poly3DCollection(tri, facecolors=np.stack([shade, shade, 0.95 * shade], 1),
                                             edgecolors="none", zorder=1))
        if len(edges):
            ax.add_collection3d(Line3DCollection(v[edges], colors="red", linewidths=2, zorder=5))
        lo, hi = v.min(0), v.max(0)
        c, r = (lo + hi) / 2, (hi - lo).max() / 2
        ax.set_xlim(c[0] - r, c[0] + r)
        ax.set_ylim(c[1] - r, c[1] + r)
        ax.set_zlim(c[2] - r, c[2] + r)
        ax.view_init(elev, azim)
        ax.invert_zaxis()  # the bench stands the statue head down
        ax.set_box_aspect((1, 1, 1), zoom=1.6)
        ax.set_axis_off()
        ax.set_title("%s: %d open edges" % (label, len(edges)))
    fig.suptitle(title)
    plt.subplots_adjust(left=0, right=1, bottom=0, top=0.93, wspace=0, hspace=0.05)
    fig.savefig(out, dpi=80)


if __name__ == "__main__":
    main()
