#!/usr/bin/python3
"""Sample PPEs from real scenes for solver benchmarks (docs/solvers.md#sample-matrices): the inlet channel
(poiseuille), the screw channel (rotating) and the dam break, each at about 1e4 and 1e5 unknowns, and the 3-D dam break
(SPHERIC Test 2) at about 1e5 and 1e6. Each case runs its
app with --export-ppe at one step and keeps the step's A (symmetric Matrix Market, with the exporter's header: scene,
step, time, l0, radius, gamma, rho) and b, gzip-compressed, in data/ppe/, and its row in data/ppe/index.csv (file,
scene, the options, the command that repeats it, step, time, unknowns, nonzeros, SHA-256 of the uncompressed A and
b).

A case runs from its options spelled out in full: data/ppe/NAME.toml, the config.toml its first run wrote (every
option, defaults included), so a later change of an app's defaults does not move the samples. The matrices (3 MB
compressed each at ~1e4, about 30 MB at ~1e5) are made on demand and ignored by git; the index and the options are
committed.

  scripts/make_sample_ppes.py BUILD_DIR [NAME|small|large|huge|all ...]   make the cases (default: small) into data/ppe/
  scripts/make_sample_ppes.py BUILD_DIR --check NAME                 make NAME in a scratch directory and compare it
                                                                      with data/ppe/index.csv (and the file on disk, if any)
Every run uses one OpenMP thread; a run is bitwise repeatable, so a case made again gives the same bytes as long as
the code that assembles its PPE has not changed (the test SamplePpesRecreated checks channel_1e4).
"""
import argparse
import csv
import gzip
import hashlib
import io
import os
import subprocess
import sys
import tempfile
from pathlib import Path

SOURCE = Path(__file__).resolve().parent.parent
DATA = SOURCE / "data" / "ppe"
INDEX = DATA / "index.csv"
FIELDS = ["file", "scene", "options", "command", "step", "time_s", "unknowns", "nonzeros", "mtx_sha256", "rhs_sha256",
          "made_by"]

# name: (app, scene, the options of the first run, the exported step, small: made by default). The step sits shortly
# before the end of each run, so a run stops soon after writing it.
CASES = {
    "channel_1e4": ("poiseuille", "inlet channel, Re 40, 25 across",
                    "--mode inlet --re 40 --across 25 --end-time 0.35 --frames 0", 50, True),
    "channel_1e5": ("poiseuille", "inlet channel, Re 40, 80 across",
                    "--mode inlet --re 40 --across 80 --end-time 0.11 --frames 0", 50, False),
    "screw_1e4": ("rotating", "screw channel (moving boundary), 81 across",
                  "--scene channel --model moving --across 81 --times 0.0018 --frames 0", 50, True),
    "screw_1e5": ("rotating", "screw channel (moving boundary), 256 across",
                  "--scene channel --model moving --across 256 --times 0.00018 --frames 0", 50, False),
    "dambreak_1e4": ("dambreak", "classic dam break, dx 2 mm",
                     "--column classic --tank-length 4 --pressure-treatment none --dx 0.002 --end-time 0.043 "
                     "--frames 0", 250, True),
    "dambreak_1e5": ("dambreak", "classic dam break, dx 0.65 mm",
                     "--column classic --tank-length 4 --pressure-treatment none --dx 0.00065 --end-time 0.0445 "
                     "--frames 0", 800, False),
    # SPHERIC Test 2, the 3-D dam break against a box: 4.1 l0 Laplacian, ~290 nonzeros a row against 2-D's ~51
    "dambreak3d_1e5": ("dambreak", "3-D dam break (SPHERIC Test 2), dx 2 cm",
                       "--dim 3 --dx 0.02 --end-time 0.13 --frames 0", 100, False),
    # at the fifth step, the column still at rest: a later one would take hours at this size
    "dambreak3d_1e6": ("dambreak", "3-D dam break (SPHERIC Test 2), dx 9 mm, fifth step",
                       "--dim 3 --dx 0.009 --end-time 0.0035 --frames 0", 5, False),
}
# huge: the ~1e6 case (7 minutes of run, 1.2 GB compressed, about 10 GB of memory), made only when named
GROUPS = {"small": [n for n, c in CASES.items() if c[4]],
          "large": [n for n, c in CASES.items() if not c[4] and not n.endswith("_1e6")],
          "huge": [n for n in CASES if n.endswith("_1e6")], "all": list(CASES)}


def sha256(data):
    return hashlib.sha256(data).hexdigest()


def gzip_bytes(data):
    """gzip without a name or a time stamp in its header, so the same text gives the same file."""
    buffer = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", fileobj=buffer, compresslevel=9, mtime=0) as out:
        out.write(data)
    return buffer.getvalue()


def counts(matrix_text):
    """(unknowns, nonzeros of the full matrix, the step's time from the header) of a symmetric Matrix Market text."""
    lines = iter(matrix_text.splitlines())
    time = ""
    for line in lines:
        if line.startswith(b"% step "):  # "% step 50, t = 335.2 s, dt = ..."
            time = line.split(b"t = ")[1].split(b" ")[0].decode()
        if not line.startswith(b"%"):
            rows, _, stored = map(int, line.split())
            break
    diagonal = sum(1 for line in lines if line.split()[0] == line.split()[1])
    return rows, 2 * stored - diagonal, time


def make(build, name, scratch):
    """Runs case `name` into `scratch`; returns (row of the index, A's text, b's text)."""
    app, scene, args, step, small = CASES[name]
    config = DATA / f"{name}.toml"
    exe = Path(build) / "apps" / app / app
    out = Path(scratch) / name
    # the first run: its config.toml becomes the case's fixed options
    options = ["--config", str(config)] if config.exists() else [*args.split(), "--export-ppe", str(step)]
    proc = subprocess.run([str(exe), *options, "--out", str(out)], env=dict(os.environ, OMP_NUM_THREADS="1"),
                          capture_output=True, text=True)
    a_file, b_file = out / "ppe" / f"step_{step:06d}.mtx", out / "ppe" / f"step_{step:06d}_rhs.mtx"
    if not a_file.exists() or not b_file.exists():
        sys.exit(f"{name}: {' '.join(options)} wrote no PPE at step {step} (exit {proc.returncode}): "
                 f"{proc.stderr[-500:]}")
    if not config.exists():
        # out= is this run's scratch folder; data= (the dam break's experiments) a path of this checkout
        lines = [l for l in (out / "config.toml").read_text().splitlines() if not l.startswith(("out=", "data="))]
        config.write_text("\n".join(lines) + "\n")
    a, b = a_file.read_bytes(), b_file.read_bytes()
    unknowns, nonzeros, time = counts(a)
    row = {"file": f"{name}.mtx.gz", "scene": scene, "options": f"{args} --export-ppe {step}",
           "command": f"{app} --config data/ppe/{name}.toml --out DIR", "step": step, "time_s": time,
           "unknowns": unknowns, "nonzeros": nonzeros, "mtx_sha256": sha256(a), "rhs_sha256": sha256(b),
           "made_by": "make sample-ppes" if small else
                      f"make sample-ppes SAMPLES={'huge' if name.endswith('_1e6') else 'large'}"}
    return row, a, b


def read_index():
    if not INDEX.exists():
        return {}
    with INDEX.open() as f:
        return {row["file"]: row for row in csv.DictReader(f)}


def write_index(rows):
    with INDEX.open("w", newline="") as f:
        writer = csv.DictWriter(f, FIELDS, lineterminator="\n")
        writer.writeheader()
        for name in CASES:  # the cases' order, whatever order they were made in
            if f"{name}.mtx.gz" in rows:
                writer.writerow(rows[f"{name}.mtx.gz"])


def check(build, name):
    """Makes `name` afresh; 0 if its A and b are bitwise those the index records (and the files on disk hold)."""
    index = read_index()
    expected = index.get(f"{name}.mtx.gz")
    if expected is None:
        print(f"{name}: not in {INDEX}")
        return 1
    with tempfile.TemporaryDirectory() as scratch:
        row, a, b = make(build, name, scratch)
    problems = []
    for key in ("unknowns", "nonzeros", "mtx_sha256", "rhs_sha256"):
        if str(row[key]) != str(expected[key]):
            problems.append(f"{key} {row[key]}, the index says {expected[key]}")
    for made, suffix in ((a, ".mtx.gz"), (b, "_rhs.mtx.gz")):
        kept = DATA / f"{name}{suffix}"
        if kept.exists() and gzip.decompress(kept.read_bytes()) != made:
            problems.append(f"{kept.name} holds other bytes than the case makes now")
    print(f"{name}: {row['unknowns']} unknowns, {row['nonzeros']} nonzeros, A {row['mtx_sha256'][:16]}..., "
          f"b {row['rhs_sha256'][:16]}...")
    for p in problems:
        print(f"FAIL {name}: {p}")
    if problems:
        print("The PPE this case assembles has changed. If the change is meant, run `make sample-ppes SAMPLES=all` and "
              "commit data/ppe/index.csv (the matrices themselves are not committed).")
    return 1 if problems else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("build", help="the build directory holding apps/")
    parser.add_argument("cases", nargs="*", default=["small"], help="case names, or small, large, huge, all")
    parser.add_argument("--check", metavar="NAME", help="make NAME in a scratch directory and compare; write nothing")
    args = parser.parse_args()
    if args.check:
        return check(args.build, args.check)
    names = []
    for c in args.cases:
        for n in GROUPS.get(c, [c]):
            if n not in CASES:
                parser.error(f"unknown case {n!r}: choose from {', '.join(CASES)}, small, large, huge, all")
            names.append(n)
    DATA.mkdir(parents=True, exist_ok=True)
    index = read_index()
    for name in names:
        with tempfile.TemporaryDirectory() as scratch:
            row, a, b = make(args.build, name, scratch)
        old = index.get(row["file"])
        if old and (old["mtx_sha256"], old["rhs_sha256"]) != (row["mtx_sha256"], row["rhs_sha256"]):
            print(f"{name}: the PPE differs from the one index.csv recorded (the code changed?); index updated")
        (DATA / f"{name}.mtx.gz").write_bytes(gzip_bytes(a))
        (DATA / f"{name}_rhs.mtx.gz").write_bytes(gzip_bytes(b))
        index[row["file"]] = row
        write_index(index)
        size = (DATA / f"{name}.mtx.gz").stat().st_size
        print(f"{name}: {row['unknowns']} unknowns, {row['nonzeros']} nonzeros, {len(a) / 1e6:.1f} MB of text, "
              f"{size / 1e6:.1f} MB compressed ({row['command']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
