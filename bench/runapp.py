"""Run one scene app and read what it wrote: the process, its summary.json (empty if none) and the wall time."""
import json
import os
import subprocess
import time


def run_app(cmd, out):
    summary_path = os.path.join(out, "summary.json")
    if os.path.exists(summary_path):
        os.remove(summary_path)  # a run that writes none must not be read as an earlier one's
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    summary = {}
    if os.path.exists(summary_path):
        with open(summary_path) as f:
            summary = json.load(f)
    return proc, summary, wall
