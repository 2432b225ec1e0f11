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

  scripts/obstacle_tank.py OUT.csv [--across 20] [--block 2.0,2.5,0.5]   (block: x from, x to, height, in a)
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="the CSV file to write")
    parser.add_argument("--across", type=int, default=20, help="particles across the column (default 20: l0 = a/20)")
    parser.add_argument("--block", default="2.0,2.5,0.5", help="the block's x from, x to and height, in a")
    args = parser.parse_args()
    l0, rows = particles(args.across, [float(v) for v in args.block.split(",")])
    with open(args.out, "w") as out:
        out.write(f"# the classic dam break with a block on the floor (scripts/obstacle_tank.py), spacing {l0!r} m\n")
        out.write("x,y,kind,group\n")
        for x, y, kind, group in rows:
            out.write(f"{x!r},{y!r},{kind},{group}\n")
    print(f"wrote {len(rows)} particles to {args.out} (spacing {l0!r} m)")


if __name__ == "__main__":
    main()
