"""Cost per particle of each core phase against N, from bench_core's CSV (log-log).
Usage: /usr/bin/python3 bench/plot_core.py bench/results/core.csv bench/results/core.png"""
import csv
import datetime
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import stamp  # noqa: E402

# In the CSV's phase_index order; neighbors_2.1 restricts the 4.1 list, neighbors_4.1+2.1 is the one search
# filling both that the time loop uses.
PHASES = ["bin", "neighbors_4.1", "neighbors_2.1", "number_density", "assemble_ppe", "reorder", "neighbors_4.1+2.1"]

rows = list(csv.DictReader(open(sys.argv[1])))
fig, ax = plt.subplots(figsize=(6.4, 4.2))
for k, name in enumerate(PHASES):
    pts = [(float(r["particles"]), float(r["ns_per_particle"])) for r in rows if int(float(r["phase_index"])) == k]
    if pts:
        ax.loglog(*zip(*pts), "o-", label=name)
ax.set_xlabel("particles N")
ax.set_ylabel("time per particle [ns] (flat = O(N))")
ax.set_title(f"SparseMPS core phases, {stamp.machine()}, {datetime.date.today()}, commit {stamp.commit()}",
             fontsize=9)
ax.grid(True, which="both", alpha=0.3)
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=90)
print("wrote", sys.argv[2])
