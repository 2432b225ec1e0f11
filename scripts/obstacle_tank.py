#!/usr/bin/python3
"""A particle file for the dam break: the classic column (a = 0.146 m wide, 2a high, in a tank 4a x 3a) with a block
on the floor in the surge's path. Run it with

  scripts/obstacle_tank.py obstacle.csv
  build/release/apps/dambreak/dambreak --particles obstacle.csv --out runs/obstacle

Every particle sits on one lattice of spacing l0 = a / ACROSS, at cell centres ((i + 1/2) l0, (j + 1/2) l0), as the
library's fill_rectangle and add_rectangle_walls place them: the water, the tank's walls (one wall layer, four dummy
layers, open at the top) and the block, whose faces the water can reach (left, top, right) are wall particles and
whose inside is dummy particles. The block's particles carry group 1, so a frame tells them apart. Only the standard
library: any python3 runs it.

With --dim 3 the same in 3-D: the column and tank extruded across a width W (--width, in a), walls on all four sides
and the floor, and the block a pillar that spans only part of the width (--block x from, x to, height, y from, y to),
so the water flows round it as well as over it. Run it with dambreak --dim 3 --particles.

  scripts/obstacle_tank.py OUT.csv [--across 20] [--block 2.0,2.5,0.5]   (block: x from, x to, height, in a)
  scripts/obstacle_tank.py OUT.csv --dim 3 [--across 10] [--width 1] [--block 2.0,2.5,0.5,0.2,0.8]
"""
import argparse


def particles(across, block):
    a = 0.146
    l0 = a / across
    nx, ny = 4 * across, 3 * across  # the tank's inner size in cells
    rows = []
    for j in range(2 * across):  # the water column, a x 2a
        for i in range(across):
            rows.append((i, j, "fluid", 0))
    layers = 5  # one wall layer, four dummy layers
    for j in range(-layers, ny):  # the tank: left, right and bottom, as add_rectangle_walls places them
        for i in range(-layers, nx + layers):
            layer = max(-i, i - nx + 1, -j, 0)
            if layer > 0:
                rows.append((i, j, "wall" if layer == 1 else "dummy", 0))
    x0, x1, height = (round(v * across) for v in block)  # in cells
    if not (across <= x0 < x1 <= nx and 0 < height < ny):
        raise SystemExit(f"the block {block} (in a) must lie on the floor between the water and the right wall")
    for j in range(height):
        for i in range(x0, x1):
            face = i == x0 or i == x1 - 1 or j == height - 1  # reachable by the water
            rows.append((i, j, "wall" if face else "dummy", 1))
    return l0, [((i + 0.5) * l0, (j + 0.5) * l0, kind, group) for i, j, kind, group in rows]


def particles_3d(across, width, block):
    """The same in 3-D, z up: rows (x, y, z, kind, group), as fill_box and add_box_walls place them."""
    a = 0.146
    l0 = a / across
    nx, ny, nz = 4 * across, round(width * across), 3 * across  # the tank's inner size in cells
    rows = []
    for k in range(2 * across):  # the water column, a x W x 2a
        for j in range(ny):
            for i in range(across):
                rows.append((i, j, k, "fluid", 0))
    layers = 5  # one wall layer, four dummy layers, round the four sides and under the floor
    for k in range(-layers, nz):
        for j in range(-layers, ny + layers):
            for i in range(-layers, nx + layers):
                layer = max(-i, i - nx + 1, -j, j - ny + 1, -k, 0)
                if layer > 0:
                    rows.append((i, j, k, "wall" if layer == 1 else "dummy", 0))
    x0, x1, height, y0, y1 = (round(v * across) for v in block)  # in cells
    if not (across <= x0 < x1 <= nx and 0 < height < nz and 0 <= y0 < y1 <= ny):
        raise SystemExit(f"the block {block} (in a) must lie on the floor between the water and the far wall")
    for k in range(height):
        for j in range(y0, y1):
            for i in range(x0, x1):
                face = i in (x0, x1 - 1) or j in (y0, y1 - 1) or k == height - 1  # reachable by the water
                rows.append((i, j, k, "wall" if face else "dummy", 1))
    return l0, [((i + 0.5) * l0, (j + 0.5) * l0, (k + 0.5) * l0, kind, group) for i, j, k, kind, group in rows]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="the CSV file to write")
    parser.add_argument("--dim", type=int, choices=(2, 3), default=2, help="2 (default) or 3")
    parser.add_argument("--across", type=int, help="particles across the column (default 20 in 2-D, 10 in 3-D)")
    parser.add_argument("--width", type=float, default=1.0, help="3-D: the tank's and column's width, in a")
    parser.add_argument("--block", help="the block's x from, x to and height, in a (default 2.0,2.5,0.5); in 3-D also "
                                        "its y from and y to (default 0.2,0.8 of the width)")
    args = parser.parse_args()
    if args.dim == 2:
        block = [float(v) for v in (args.block or "2.0,2.5,0.5").split(",")]
        if len(block) != 3:
            raise SystemExit("--block takes x from, x to and height in 2-D")
        l0, rows = particles(args.across or 20, block)
        header = "x,y,kind,group"
    else:
        block = [float(v) for v in (args.block or f"2.0,2.5,0.5,{0.2 * args.width},{0.8 * args.width}").split(",")]
        if len(block) != 5:
            raise SystemExit("--block takes x from, x to, height, y from and y to in 3-D")
        l0, rows = particles_3d(args.across or 10, args.width, block)
        header = "x,y,z,kind,group"
    with open(args.out, "w") as out:
        out.write(f"# the classic dam break with a block on the floor (scripts/obstacle_tank.py), {args.dim}-D, "
                  f"spacing {l0!r} m\n")
        out.write(header + "\n")
        for row in rows:
            out.write(",".join(repr(v) if isinstance(v, float) else str(v) for v in row) + "\n")
    print(f"wrote {len(rows)} particles to {args.out} (spacing {l0!r} m)")


if __name__ == "__main__":
    main()
