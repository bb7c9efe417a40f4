"""The browser check's pictures side by side: potree-core in Chromium, VTK with the same points,
VTK with the whole cloud (all from the same camera).

Usage: browser_figure.py WORK_DIR OUT.png
WORK_DIR is the folder check_potree_browser.py wrote (browser.json, browser.json.png, vtk.png,
vtk_whole.png).
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402


def main():
    work, out = sys.argv[1], sys.argv[2]
    found = json.load(open(os.path.join(work, "browser.json")))
    nodes = found["visibleNodes"]
    shown = sum(n["numPoints"] for n in nodes)
    titles = [
        "potree-core 2.0 in Chromium, default budget:\nthe %d nodes it loaded (%s points)" % (len(nodes), f"{shown:,}"),
        "VTK, same camera: the same points",
        "VTK, same camera: the whole cloud",
    ]
    pictures = ["browser.json.png", "vtk.png", "vtk_whole.png"]
    fig, axes = plt.subplots(1, 3, figsize=(12, 4))
    for ax, title, name in zip(axes, titles, pictures):
        ax.imshow(mpimg.imread(os.path.join(work, name)))
        ax.set_title(title, fontsize=9)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(out, dpi=100)


if __name__ == "__main__":
    main()
