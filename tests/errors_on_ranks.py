#!/usr/bin/python3
"""An error on any rank ends every rank (docs/input-checks.md, "The apps under mpirun").

Each case runs an app under `mpirun -np P` with input that fails on every rank alike (an option refused after
parsing) or on one rank alone (an output folder rank 0 cannot make, the inlet's ghost pool running dry on the rank
that holds the plate). Asserted: a non-zero exit, the cause on stderr (once when every rank met it), and an end
within HANG_SECONDS (before this check one rank's error left the others waiting forever). A failure during the run
also leaves summary.json with status "failed" and the reason.

  tests/errors_on_ranks.py BUILD_DIR MPIEXEC RANKS
"""
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HANG_SECONDS = 60  # a hang, not a speed limit: these cases end in 1-4 s


def main() -> int:
    build, mpiexec, ranks = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
    dambreak = str(build / "apps/dambreak/dambreak")
    poiseuille = str(build / "apps/poiseuille/poiseuille")
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1")
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "a_file").write_text("not a folder\n")
        # (name, command, text the error must hold, the error met by every rank, summary.json expected in)
        cases = [
            ("out is a file", [dambreak, "--out", str(tmp / "a_file")], "not a directory", True, None),
            ("out below a device", [poiseuille, "--out", "/dev/full/x"], "/dev/full is not a directory", True, None),
            ("out rank 0 cannot make", [dambreak, "--end-time", "0.01", "--out", "/proc/sparsemps-out"],
             "cannot use the output folder /proc/sparsemps-out", False, None),
            ("export refused on ranks", [dambreak, "--export-ppe", "3", "--out", str(tmp / "export")],
             "--export-ppe writes the PPE of one process", True, None),
            ("ghost pool runs dry", [poiseuille, "--mode", "inlet", "--across", "8", "--channel-length", "4",
                                     "--station", "2", "--end-time", "0.2", "--dt-factor", "50", "--out",
                                     str(tmp / "pool")], "ghost particles", False, tmp / "pool"),
        ]
        for name, command, cause, everyone, summary_dir in cases:
            start = time.monotonic()
            try:
                done = subprocess.run([mpiexec, "--oversubscribe", "--mca", "btl", "self,vader", "-np", str(ranks)] +
                                      command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                      timeout=HANG_SECONDS)
            except subprocess.TimeoutExpired:
                failures.append(f"{name}: still running after {HANG_SECONDS} s")
                continue
            seconds = time.monotonic() - start
            print(f"{name}: exit {done.returncode} after {seconds:.1f} s")
            if done.returncode == 0:
                failures.append(f"{name}: exit 0")
            said = done.stdout.count(cause)
            if said == 0:
                failures.append(f"{name}: '{cause}' not said:\n{done.stdout[-2000:]}")
            elif everyone and said != 1:
                failures.append(f"{name}: an error every rank met was said {said} times, not once")
            if summary_dir is not None:
                summary = json.loads((summary_dir / "summary.json").read_text())
                if summary.get("status") != "failed" or cause not in summary.get("error", ""):
                    failures.append(f"{name}: summary.json does not record the failure: {summary.get('status')}")
    for failure in failures:
        print("FAIL", failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
