#!/usr/bin/python3
"""Frames of a run side by side: fluid coloured by pressure, walls dark grey, dummies light grey (Debian's
python3-vtk9 reads the frames, matplotlib draws them).

  scripts/plot_frames.py OUT.png FRAME.vtp [FRAME.vtp ...] [--pmax PA] [--box x0,x1,y0,y1]

A 3-D frame is drawn on two of its axes (--axes xz: a side view, xy: from above) with the particles in a slab of the
third (--slab lo,hi [m]), so that the water in front does not hide what lies behind it:

  scripts/plot_frames.py OUT.png FRAME.vtp ... --axes xz --slab 0.05,0.1
"""
import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import vtk  # noqa: E402
from vtk.util.numpy_support import vtk_to_numpy  # noqa: E402


def read(path):
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    data = reader.GetOutput()
    point = data.GetPointData()
    return (vtk_to_numpy(data.GetPoints().GetData()), vtk_to_numpy(point.GetArray("kind")),
            vtk_to_numpy(point.GetArray("pressure")), float(vtk_to_numpy(data.GetFieldData().GetArray("TIME"))[0]))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out")
    parser.add_argument("frames", nargs="+")
    parser.add_argument("--pmax", type=float, default=None, help="top of the pressure colour scale [Pa]")
    parser.add_argument("--box", default=None, help="x0,x1,y0,y1 shown [m] (default: every particle)")
    parser.add_argument("--axes", default="xy", choices=("xy", "xz", "yz"), help="the two axes drawn (default xy)")
    parser.add_argument("--slab", default=None, help="lo,hi: only particles with the third axis in [lo, hi] [m]")
    args = parser.parse_args()
    shown_axes = ["xyz".index(a) for a in args.axes]
    depth = ({0, 1, 2} - set(shown_axes)).pop()
    frames = []
    for f in args.frames:
        r, kind, p, t = read(f)
        keep = slice(None)
        if args.slab:
            lo, hi = (float(v) for v in args.slab.split(","))
            keep = (r[:, depth] >= lo) & (r[:, depth] <= hi)
        frames.append((r[keep][:, shown_axes], kind[keep], p[keep], t))
    pmax = args.pmax or max(p[k == 0].max(initial=1.0) for _, k, p, _ in frames)
    fig, axes = plt.subplots(1, len(frames), figsize=(3.6 * len(frames), 3.0), squeeze=False)
    for ax, (xy, kind, p, t) in zip(axes[0], frames):
        size = max(0.3, 8000 / max(len(xy), 1))  # marker area [pt^2]: about a spacing wide at this size
        for k, colour in ((2, "0.8"), (1, "0.35")):
            ax.scatter(xy[kind == k, 0], xy[kind == k, 1], s=size, c=colour, linewidths=0)
        fluid = kind == 0
        shown = ax.scatter(xy[fluid, 0], xy[fluid, 1], s=size, c=p[fluid], cmap="viridis", vmin=0, vmax=pmax,
                           linewidths=0)
        ax.set_aspect("equal")
        ax.set_title(f"t = {t:.2f} s", fontsize=10)
        if args.box:
            x0, x1, y0, y1 = (float(v) for v in args.box.split(","))
            ax.set_xlim(x0, x1)
            ax.set_ylim(y0, y1)
        ax.tick_params(labelsize=8)
        ax.set_xlabel(f"{args.axes[0]} [m]", fontsize=8)
        if ax is axes[0][0]:
            ax.set_ylabel(f"{args.axes[1]} [m]", fontsize=8)
    fig.colorbar(shown, ax=axes[0].tolist(), label="fluid pressure [Pa]", shrink=0.85)
    fig.savefig(args.out, dpi=120, bbox_inches="tight")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
