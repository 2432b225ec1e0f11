#!/usr/bin/python3
"""The acoustic app's accuracy and stability studies (seed 001, Fig. 2-3), written as CSV.

  cfl      relative RMS error of the free-field pulse against CFL = c0 dt / l0 at l0 = 0.5 m (Fig. 2), for the
           MPS gradient (Mur at every stage, Mur once per step, hard walls) and the least-squares one (Mur);
           each run goes on to at least
           --stability-steps steps so that a CFL beyond RK4's limit has time to be caught by the guard.
  spacing  relative RMS error against l0 at CFL 0.17 (Fig. 3).

Every run is the app's own command (printed), its numbers read back from its summary.json. Runs that the
guard stops are rows with status "unstable" and the guard's step and time.

  acoustic_studies.py --app build/release/apps/acoustic/acoustic cfl --out bench/results/acoustic_cfl.csv
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile

SAMPLES = [0.025, 0.05, 0.1]
C0 = 340.0

CFL_VALUES = {
    "mps": [0.05, 0.1, 0.136, 0.2, 0.3, 0.5, 0.68, 1.0, 1.5, 2.0, 2.5, 2.65, 2.7, 2.75, 2.8, 3.0],
    "ls3": [0.05, 0.1, 0.136, 0.2, 0.3, 0.5, 0.68, 1.0, 1.3, 1.4, 1.45, 1.5, 1.6],
}
SPACINGS = [2.0, 1.0, 0.8, 0.5, 0.4, 0.25, 0.2, 0.125]


def run(app, args, workdir):
    out = os.path.join(workdir, "run")
    cmd = [app, "--case", "free", "--no-maps", "--frames", "0", "--out", out] + args
    print("$ " + " ".join(cmd), flush=True)
    proc = subprocess.run(cmd, capture_output=True, text=True)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    if proc.returncode not in (0, 1):
        sys.exit(f"app failed ({proc.returncode}): {proc.stderr}")
    return summary


def row_of(summary, study_keys):
    p = summary["parameters"]
    row = dict(study_keys)
    row.update({"gradient": p["gradient"], "boundary": p["boundary"], "l0_m": p["l0_m"], "cfl": p["cfl"],
                "half_width_m": p["pulse"]["b_m"], "status": "stable" if summary["status"] == "completed" else "unstable",
                "steps": summary["steps"], "time_s": summary["time_s"],
                "stable_cfl_estimate": summary["stable_cfl"],
                "per_step_spmv_equivalents": summary["timings"]["per_step_spmv_equivalents"],
                "per_step_s": summary["timings"]["per_step_median_s"]})
    errors = {round(s["time_s"], 6): s["relative_rms_error"] for s in summary["samples"]}
    for t in SAMPLES:
        match = [e for ts, e in errors.items() if abs(ts - t) <= 0.5 * p["dt_s"] + 1e-12]
        row[f"error_t{t}"] = match[0] if match else ""
    row["guard_message"] = summary.get("error", "")
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--app", required=True, help="path of the acoustic executable")
    ap.add_argument("study", choices=["cfl", "spacing"])
    ap.add_argument("--out", required=True, help="CSV to write")
    ap.add_argument("--b", type=float, default=3.0, help="pulse half-width [m]")
    ap.add_argument("--stability-steps", type=int, default=2000)
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as work:
        if a.study == "cfl":
            l0 = 0.5
            for gradient, boundaries in (("mps", ["mur", "mur-step", "hard"]), ("ls3", ["mur"])):
                for boundary in boundaries:
                    for cfl in CFL_VALUES[gradient]:
                        dt = cfl * l0 / C0
                        end = max(SAMPLES[-1], a.stability_steps * dt)
                        s = run(a.app, ["--l0", str(l0), "--cfl", str(cfl), "--b", str(a.b), "--gradient", gradient,
                                        "--boundary", boundary, "--end-time", f"{end:.9g}",
                                        "--samples", ",".join(map(str, SAMPLES))], work)
                        rows.append(row_of(s, {}))
                        r = rows[-1]
                        print(f"  {gradient}/{boundary} CFL {cfl}: {r['status']} after {r['steps']} steps, "
                              f"error at 0.1 s {r['error_t0.1']}", flush=True)
        else:
            cfl = 0.17
            for gradient in ("mps", "ls3"):
                for l0 in SPACINGS:
                    s = run(a.app, ["--l0", str(l0), "--cfl", str(cfl), "--b", str(a.b), "--gradient", gradient,
                                    "--end-time", str(SAMPLES[-1]), "--samples", ",".join(map(str, SAMPLES))], work)
                    rows.append(row_of(s, {}))
                    print(f"  {gradient} l0 {l0}: error at 0.1 s {rows[-1]['error_t0.1']}", flush=True)
    with open(a.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    print("wrote " + a.out)


if __name__ == "__main__":
    main()
