#!/usr/bin/python3
"""A frame (.vtp, as the apps write them) as a particle file (CSV: x, y, kind, u, v, p, group), read by Debian's
python3-vtk9, every value written to the last bit, so that `dambreak --particles` can start from it
(docs/particle-files.md).

  scripts/frame_to_csv.py FRAME.vtp OUT.csv
"""
import sys

import vtk
from vtk.util.numpy_support import vtk_to_numpy


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__.strip().splitlines()[-1].strip())
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(sys.argv[1])
    reader.Update()
    data = reader.GetOutput()
    arrays = data.GetPointData()
    if data.GetPoints() is None or any(arrays.GetArray(a) is None for a in ("velocity", "pressure", "kind", "group")):
        sys.exit(f"{sys.argv[1]}: not a SparseMPS frame (points with velocity, pressure, kind and group)")
    xy, uv = vtk_to_numpy(data.GetPoints().GetData()), vtk_to_numpy(arrays.GetArray("velocity"))
    p, kind, group = (vtk_to_numpy(arrays.GetArray(a)) for a in ("pressure", "kind", "group"))
    names = {0: "fluid", 1: "wall", 2: "dummy"}
    with open(sys.argv[2], "w") as out:
        out.write(f"# from {sys.argv[1]} (scripts/frame_to_csv.py)\nx,y,kind,u,v,p,group\n")
        for k in range(len(xy)):  # repr: the shortest text that reads back as the same double
            out.write(f"{float(xy[k, 0])!r},{float(xy[k, 1])!r},{names[int(kind[k])]},{float(uv[k, 0])!r},"
                      f"{float(uv[k, 1])!r},{float(p[k])!r},{int(group[k])}\n")
    print(f"wrote {len(xy)} particles to {sys.argv[2]}")


if __name__ == "__main__":
    main()
