#!/usr/bin/python3
"""A communication model of the distributed step, fitted to this machine's measurements, and its projection to 1e8
particles on 1,000 ranks (issue 27, item 5; docs/scaling.md#the-model-and-the-projection); with --dim 3, fitted to the
3-D dam break's measurements and projected to 1e9 particles on 10,000 ranks (issue 39).

Per rank and step, for n particles per rank on P ranks (RCB boxes; 2D written out, 3D below):

  T(n, P) = T1(n) + T_ppe_loss(n, P) + T_halo(n, P) + T_collective(P)

  T1(n)          the step on one rank (no exchanges): a power law a n^b through the measured 1-rank steps;
  T_ppe_loss     what the PPE (AMG setup and PCG) loses to parallel inefficiency: T1's PPE share (1/e - 1) for a
                 parallel efficiency e of the pressure solve (an assumption at 1,000 ranks: see ASSUMED);
  T_halo         per neighbour rank and step, E exchanges of one message each; per side of the box k sqrt(n) copies
                 (k fitted to the measured copies on 2 ranks), each carrying BYTES_PER_COPY bytes over the step's
                 exchanges; 8 neighbours for an interior box (4 sides, 4 corners of ~w^2 copies): messages alpha each,
                 bytes at beta (the network's) plus the packing measured here;
  T_collective   the step's allreduces and the PCG's two per iteration, each 2 log2(P) alpha.

In 3D a box's face holds n^(2/3) particles: k n^(2/3) copies per face, and an interior box has 26 neighbours (6
faces; 12 edges of w^2 n^(1/3) copies; 8 corners of w^3), w = k / 2 rows as in 2D.

alpha and beta of this machine (shared memory, OpenMPI's vader) are fitted to the distributed PPE bench's timed
refreshes of one field (bench/results/distributed_ppe.csv, the idle runs): they include packing and unpacking.
The network's are assumed (ASSUMED below): a cluster was not available to measure them.

  /usr/bin/python3 bench/scaling_model.py [--dim 2] [--step-csv bench/results/distributed_scaling.csv]
      [--ppe-csv bench/results/distributed_ppe.csv] [--png bench/results/scaling_model.png]
  /usr/bin/python3 bench/scaling_model.py --dim 3   (bench/results/distributed_step_3d.csv, scaling_model_3d.png)
"""
import argparse
import csv
import math
import sys
from pathlib import Path

# Not measured here: a cluster's interconnect and AMG's efficiency at 1,000 ranks.
ASSUMED = {
    "network_latency_s": 2e-6,          # one point-to-point message, InfiniBand-class
    "network_bandwidth_bytes_per_s": 10e9,
    "ppe_efficiency_1000_ranks": 0.90,  # Guo et al. (CPC 2018): > 90 % in the pressure solve to 6,144 partitions
}
NEIGHBOURS_INTERIOR = 8
IDLE_LOAD = 1.2  # rows measured at a 1-minute load average above this are left out (another job on a core)


def rows(path: Path) -> list:
    with open(path) as f:
        return [r for r in csv.DictReader(f)]


def fit_power(points: list) -> tuple:
    """Least squares of log t = log a + b log n."""
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else 1.0
    return math.exp(my - b * mx), b


def median(values: list) -> float:
    v = sorted(values)
    return v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2)
    ap.add_argument("--step-csv")
    ap.add_argument("--ppe-csv", default="bench/results/distributed_ppe.csv")
    ap.add_argument("--png")
    ap.add_argument("--kind-weights", help="3-D: the rows run with these kind weights (as the CSV writes them)")
    args = ap.parse_args()
    dim = args.dim
    suffix = "" if dim == 2 else "_3d"
    args.step_csv = args.step_csv or ("bench/results/distributed_scaling.csv" if dim == 2
                                      else "bench/results/distributed_step_3d.csv")
    args.png = args.png or f"bench/results/scaling_model{suffix}.png"
    total_particles, total_ranks = (1e8, 1000) if dim == 2 else (1e9, 10000)

    # One script made every row of the step's file with no other job on the machine (its own 2-rank runs raise the
    # 1-minute load average the next run starts at, so the load is not a filter here).
    steps = rows(Path(args.step_csv))
    if args.kind_weights:
        steps = [r for r in steps if r.get("kind_weights") == args.kind_weights]
    one = [r for r in steps if int(r["ranks"]) == 1]
    two = [r for r in steps if int(r["ranks"]) == 2]
    if len({r["particles"] for r in one}) < 2 or not two:
        print("need idle 1-rank runs at two sizes or more and 2-rank runs", file=sys.stderr)
        return 1

    # T1(n): the 1-rank step, median per size.
    by_size = {}
    for r in one:
        by_size.setdefault(int(r["particles"]), []).append(r)
    t1_points = [(n, median([float(r["step_s"]) for r in rs])) for n, rs in sorted(by_size.items())]
    ppe_share = [(n, median([(float(r["setup_s"]) + float(r["solve_s"])) / float(r["step_s"]) for r in rs]))
                 for n, rs in sorted(by_size.items())]
    a, b = fit_power(t1_points)

    # Halo: copies on the larger rank per owned^((D-1)/D) (a cut's face), and bytes per copy over a step's exchanges.
    face = (dim - 1) / dim
    k = median([float(r["halo_copies_max"]) / float(r["owned_max"]) ** face for r in two])
    bytes_per_copy = median([float(r["bytes_per_step"]) / float(r["halo_copies_sum"]) for r in two])
    messages_per_neighbour = median([float(r["messages_per_step"]) / 2.0 for r in two])  # 2 ranks, 1 neighbour each
    # The PPE's own exchanges, not counted by the step bench: flags (1 B), held values (8), numbers and labels
    # (4 + 4), pressures after the solve (8); five messages.
    bytes_per_copy += 25.0
    messages_per_neighbour += 5.0
    iterations = median([float(r["iterations"]) for r in two])

    # alpha, beta of this machine from one-field refreshes (8 bytes a copy) on 2 ranks.
    ppe = [r for r in rows(Path(args.ppe_csv)) if int(r["ranks"]) == 2 and float(r["loadavg_1min"]) <= IDLE_LOAD]
    sizes = {}
    for r in ppe:
        sizes.setdefault(int(r["halo_copies_max"]), []).append(float(r["refresh_s"]))
    (c1, t1s), (c2, t2s) = sorted(sizes.items())[0], sorted(sizes.items())[-1]
    r1, r2 = median(t1s), median(t2s)
    beta_local = (r2 - r1) / (8.0 * (c2 - c1))
    # Two sizes cannot resolve a latency of a few microseconds (the intercept may come out below zero): 0 then.
    alpha_fit = r1 - beta_local * 8.0 * c1
    alpha_local = max(alpha_fit, 0.0)

    def t1(n: float) -> float:
        return a * n ** b

    def ppe_fraction(n: float) -> float:
        # nearest measured size's share
        return min(ppe_share, key=lambda p: abs(math.log(p[0] / n)))[1]

    def model(n: float, P: int, alpha: float, beta: float, ppe_eff: float) -> dict:
        if P == 1:
            return {"compute": t1(n), "ppe_loss": 0.0, "halo": 0.0, "collective": 0.0}
        # 2 ranks: one cut; more: an interior box, 4 sides and 4 corners (a square of the halo's width each); in 3D
        # 6 faces, 12 edges (w^2 times an edge's n^(1/3)) and 8 corners (w^3).
        width = k / 2.0  # copies per unit of cut length on one side: the halo's width in lattice rows
        if dim == 2:
            sides, corners, neighbours = (1, 0, 1) if P == 2 else (4, 4, NEIGHBOURS_INTERIOR)
            copies = sides * k * math.sqrt(n) + corners * width * width
        else:
            faces, edges, corners, neighbours = (1, 0, 0, 1) if P == 2 else (6, 12, 8, 26)
            copies = faces * k * n ** face + edges * width ** 2 * n ** (1 / 3) + corners * width ** 3
        halo = neighbours * messages_per_neighbour * alpha + copies * bytes_per_copy * beta
        allreduces = 8 + 2 * iterations
        collective = allreduces * 2 * math.log2(P) * alpha
        ppe_loss = t1(n) * ppe_fraction(n) * (1.0 / ppe_eff - 1.0)
        return {"compute": t1(n), "ppe_loss": ppe_loss, "halo": halo, "collective": collective}

    net_alpha = ASSUMED["network_latency_s"]
    net_beta = 1.0 / ASSUMED["network_bandwidth_bytes_per_s"] + beta_local  # the wire and the packing measured here

    print(f"T1(n) = {a:.3g} n^{b:.3f} s (1-rank steps: " +
          ", ".join(f"{n:.3g}: {t:.3f} s" for n, t in t1_points) + ")")
    print(f"PPE share of the 1-rank step: " + ", ".join(f"{n:.3g}: {s:.2f}" for n, s in ppe_share))
    print(f"halo: {k:.2f} copies per {'sqrt(owned)' if dim == 2 else 'owned^(2/3)'} per cut on 2 ranks; {bytes_per_copy:.0f} bytes per copy per step; "
          f"{messages_per_neighbour:.1f} messages per neighbour per step; PCG iterations {iterations:.0f}")
    print(f"this machine: beta = {beta_local * 1e9:.3f} ns/byte ({1 / beta_local / 1e9:.2f} GB/s, packing included), "
          f"alpha fitted {alpha_fit * 1e6:.2f} us (taken as {alpha_local * 1e6:.2f}), from refreshes of {c1} and {c2} "
          f"copies ({r1 * 1e6:.1f}, {r2 * 1e6:.1f} us)")

    # The PPE's parallel efficiency on 2 ranks, per size: its 1-rank time over twice its 2-rank time.
    def ppe_seconds(r):
        return float(r["setup_s"]) + float(r["solve_s"])

    print("\non 2 ranks against 1, and the model on this machine with the PPE's efficiency as measured:")
    for r in sorted(two, key=lambda r: int(r["particles"])):
        same = [o for o in one if o["particles"] == r["particles"]]
        n = float(r["owned_max"])
        if same:
            ppe1 = median([ppe_seconds(o) for o in same])
            rest1 = median([float(o["step_s"]) - ppe_seconds(o) for o in same])
            eff = ppe1 / (2 * ppe_seconds(r))
            rest_eff = rest1 / (2 * (float(r["step_s"]) - ppe_seconds(r)))
            m = model(n, 2, alpha_local, beta_local, eff)
            print(f"  {int(r['particles']):>9} particles (strong): step {float(r['step_s']):.3f} s, speed-up "
                  f"{median([float(o['step_s']) for o in same]) / float(r['step_s']):.2f}; PPE efficiency {eff:.2f}, "
                  f"the rest's {rest_eff:.2f}; model {sum(m.values()):.3f} s (halo {m['halo'] * 1e3:.2f} ms)")
    print("\nweak scaling, 2 ranks against 1 rank at about the same particles per rank:")
    for r in sorted(two, key=lambda r: int(r["particles"])):
        n = float(r["owned_max"])
        near = min(one, key=lambda o: abs(math.log(float(o["particles"]) / n)))
        if abs(math.log(float(near["particles"]) / n)) > 0.15:
            continue
        per_particle_1 = float(near["step_s"]) / float(near["particles"])
        print(f"  {n:.3g} per rank ({int(r['particles'])} on 2 ranks): step {float(r['step_s']):.3f} s against "
              f"{float(near['step_s']):.3f} s for {int(near['particles'])} on 1 rank: weak efficiency "
              f"{per_particle_1 * n / float(r['step_s']):.2f}")

    def power(x):
        return f"1e{round(math.log10(x))}"

    print(f"\nprojection: {power(total_particles)} particles on {total_ranks:,} ranks ({power(total_particles / total_ranks)} "
          f"per rank), network alpha {net_alpha * 1e6:.0f} us, {ASSUMED['network_bandwidth_bytes_per_s'] / 1e9:.0f} GB/s:")
    n, P = total_particles / total_ranks, total_ranks
    for label, eff in (("PPE efficiency 90 % (Guo et al.)", ASSUMED["ppe_efficiency_1000_ranks"]),
                       ("PPE efficiency 100 %", 1.0), ("PPE efficiency 50 %", 0.5)):
        m = model(n, P, net_alpha, net_beta, eff)
        total = sum(m.values())
        print(f"  {label}: {total:.3f} s per step = compute {m['compute']:.3f} + PPE loss {m['ppe_loss']:.3f} + "
              f"halo {m['halo'] * 1e3:.2f} ms + collectives {m['collective'] * 1e3:.2f} ms; "
              f"efficiency {m['compute'] / total:.2f}")

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing: no chart (use /usr/bin/python3)", file=sys.stderr)
        return 0
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ranks = [1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1000] + ([] if dim == 2 else [2000, 4000, 10000])
    for per_rank, colour in ((1e5, "tab:blue"), (5e5, "tab:orange")):
        for eff, style in ((ASSUMED["ppe_efficiency_1000_ranks"], "-"), (0.5, ":")):
            ts = [sum(model(per_rank, P, net_alpha, net_beta, 1.0 if P == 1 else eff).values()) for P in ranks]
            ax.plot(ranks, ts, style, color=colour,
                    label=f"model, {per_rank:.0e} per rank, PPE efficiency {eff:.0%}")
        measured = [(int(r["ranks"]), float(r["step_s"])) for r in steps
                    if abs(float(r["particles"]) / int(r["ranks"]) / per_rank - 1) < 0.15]
        if measured:
            ax.plot([p for p, _ in measured], [t for _, t in measured], "o", color=colour,
                    label=f"measured here, ~{per_rank:.0e} per rank")
    ax.set_xscale("log")
    ax.set_xlabel("ranks (weak scaling: particles per rank fixed)")
    ax.set_ylabel("time per step [s]")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(f"{'Dam-break' if dim == 2 else '3-D dam-break (SPHERIC Test 2)'} step: measured on 1-2 ranks, "
                 f"modelled to {ranks[-1]:,}", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.png, dpi=120)
    print(f"\nchart: {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
