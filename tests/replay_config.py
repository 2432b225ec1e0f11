#!/usr/bin/python3
"""Every app writes config.toml beside its summary; `app --config that-file --out elsewhere` must repeat the run
bitwise: the same exit status, the same summary (timings aside) and the same bytes in every other file it wrote.
Each case sets options away from their defaults, flags included, so that a setting the file lost would show.
Every summary must validate against docs/summary.schema.json (the shared keys and the naming rule of every key,
docs/config-files.md), with its status matching the exit status and the run record naming this run; and the schema
must reject summaries that break the rule (a dotted key, a number without its unit, a status outside the vocabulary).
Every app's --help shows its options in groups.

  tests/replay_config.py BUILD_DIR
"""
import copy
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from compare_results import comparable_bytes, schema_errors as breaks_of_schema, without_timings  # noqa: E402

CASES = {
    "poiseuille": "--mode body-force --across 10 --end-time 1 --frames 2 --gamma 0.05 --cold-start --tolerance 0.5",
    "hydrostatic": "--end-time 0.1 --window 0.05 --frames 2 --gamma 0.01",
    "rotating": "--scene channel --model moving --across 8 --times 0.05 --frames 2 --walls plain "
                "--lattice-reference --shifting 0",
    "acoustic": "--case hard --size 20 --l0 0.5 --end-time 0.05 --no-maps --frames 2",
    "dambreak": "--column classic --end-time 0.05 --frames 2 --shifting 1 --gradient plain --wet-walls",
    "structure": "--scene csm3 --end-time 0.05 --frames 2",
    "fsi": "--scene gate --end-time 0.01 --frames 2",
    # SPHERIC Test 2, the 3-D dam break, at its coarsest spacing
    "dambreak-3d": "--dim 3 --dx 0.1 --end-time 0.02 --frames 2 --wet-walls --collision 0.7",
    # Taylor-Couette in 3-D, the annulus extruded along z
    "rotating-3d": "--scene couette --dim 3 --across 6 --times 0.02 --frames 2 --walls mirror",
    # a scene from a particle file (written first by --write-particles): config.toml records the file's path
    "dambreak-particles": "--particles {tmp}/classic.csv --end-time 0.02 --frames 2 --gamma 0.05",
    # a scene file (sparsemps-run): config.toml records the file's path, the file is copied beside the results
    "run": str(Path(__file__).resolve().parent.parent / "examples" / "scenes" / "wave_paddle.toml") +
           " --end-time 0.05 --frames 2",
}
APP = {"dambreak-particles": "dambreak", "dambreak-3d": "dambreak", "rotating-3d": "rotating"}  # a case's app, where the case is not named after it
# A line each case's config.toml must hold: a switch given, and a path relative to the file's folder (tmp/CASE/first/).
FLAGS = {"poiseuille": "cold-start = true", "rotating": "lattice-reference = true", "dambreak": "wet-walls = true",
         "dambreak-3d": "wet-walls = true",
         "acoustic": "no-maps = true", "dambreak-particles": 'particles = "../../classic.csv"'}


def run(build, app, args, out):
    cmd = [str(Path(build) / "apps" / app / app), *args] + (["--out", str(out)] if out else [])
    proc = subprocess.run(cmd, env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    return proc.returncode, proc.stderr


VOCABULARY = {"passed": 0, "check failed": 2, "completed": 0, "failed": 1}


def schema_errors(app, args, out, status):
    """What in out/summary.json breaks the schema, as messages."""
    summary = json.loads((Path(out) / "summary.json").read_text())
    errors = breaks_of_schema(summary)
    if VOCABULARY.get(summary.get("status")) != status:
        errors.append(f"status {summary.get('status')!r} with exit status {status}")
    if summary.get("pass") is not (status == 0):
        errors.append(f"pass {summary.get('pass')!r} with exit status {status}")
    if not isinstance(summary.get("parameters"), dict):
        errors.append("no parameters")
    run = summary.get("run", {})
    exe = str(Path(sys.argv[1]) / "apps" / app / app)
    expected = {"app": app, "command_line": [exe, *args, "--out", str(out)], "config": "config.toml"}
    for key, value in expected.items():
        if run.get(key) != value:
            errors.append(f"run.{key} {run.get(key)!r}, expected {value!r}")
    commit = run.get("commit", "")
    if not (commit == "unknown" or (len(commit) == 12 and all(c in "0123456789abcdef" for c in commit))):
        errors.append(f"run.commit {commit!r}")
    if not run.get("version"):
        errors.append("no run.version")
    return [f"{app} {' '.join(args)}: {e}" for e in errors]


# Summaries that break the rule, each made from a real one: the schema must reject every one. (path, key, value):
# the key set to the value (or to value(old value) if callable) in the object at path; None deletes the key.
PLANTED = [
    (["checks"], "impact_0.2H", {"arrived": False}),               # a dot in a key
    (["parameters"], "width", 0.2),                                # a length without its unit
    (["parameters"], "rho", 1000.0),
    (["parameters", "radii"], "density", 4.1),                      # the same, nested
    (["parameters"], "c0_m_s", 340.0),                             # the other spelling of m/s
    (["timings"], "particle_steps_per_second", 1e6),
    (["checks"], "peak_error_percent", 1.5),                       # per cent instead of a fraction
    (["parameters"], "Re", 40.0),                                  # not snake_case
    (["parameters"], "sample_times_s", ["0.1"]),                   # a unit on text
    ([], "status", "ran"),                                         # outside the vocabulary
    ([], "pass", lambda old: not old),                             # pass that contradicts the status
    ([], "run", None),                                             # no run record
    (["run"], "commit", "HEAD"),
]


def planted_accepted(summary):
    """The planted breaks the schema let through (it must let none)."""
    accepted = []
    for path, key, value in PLANTED:
        bad = copy.deepcopy(summary)
        at = bad
        for step in path:
            at = at.setdefault(step, {})
        if value is None:
            at.pop(key, None)
        else:
            at[key] = value(at.get(key)) if callable(value) else value
        if not breaks_of_schema(bad):
            accepted.append(f"/{'/'.join(path + [key])} = {at.get(key)!r}")
    return accepted


def outputs(out):
    files = {}
    for f in sorted(Path(out).rglob("*")):
        if f.is_file() and f.name not in ("summary.json", "config.toml"):
            files[str(f.relative_to(out))] = hashlib.sha256(comparable_bytes(f)).hexdigest()
    summary = json.loads((Path(out) / "summary.json").read_text())
    summary.pop("run")  # its command line is the replay's own
    return files, without_timings(summary)


def main():
    build = sys.argv[1]
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        run(build, "dambreak", ["--write-particles", f"{tmp}/classic.csv"], None)
        for case, args in CASES.items():
            app, args = APP.get(case, case), args.format(tmp=tmp)
            first, again = Path(tmp) / case / "first", Path(tmp) / case / "again"
            status, err = run(build, app, args.split(), first)
            failures += schema_errors(app, args.split(), first, status)
            config = first / "config.toml"
            if not config.exists():
                failures.append(f"{app}: no config.toml written (exit {status}): {err[-300:]}")
                continue
            text = config.read_text()
            if case in FLAGS and FLAGS[case].format(tmp=tmp) not in text.splitlines():
                failures.append(f"{case}: config.toml lacks '{FLAGS[case].format(tmp=tmp)}'")
            status2, err2 = run(build, app, ["--config", str(config)], again)
            if status2 != status:
                failures.append(f"{app}: exit {status} first, {status2} replayed: {err2[-300:]}")
                continue
            files, summary = outputs(first)
            files2, summary2 = outputs(again)
            if files != files2:
                differ = sorted(k for k in set(files) | set(files2) if files.get(k) != files2.get(k))
                failures.append(f"{app}: files differ on replay: {differ[:5]}")
            if summary != summary2:
                keys = sorted(k for k in set(summary) | set(summary2) if summary.get(k) != summary2.get(k))
                failures.append(f"{app}: summary differs on replay in {keys}")
            replayed = (again / "config.toml").read_text()
            if [l for l in text.splitlines() if not l.startswith("out = ")] != \
                    [l for l in replayed.splitlines() if not l.startswith("out = ")]:
                failures.append(f"{app}: the replay's config.toml differs from the first run's")
            print(f"{case}: exit {status}, {len(files)} files and the summary the same on replay")
        # --help in groups: no option of any app left in CLI11's catch-all "Options" (apps/common/help.hpp).
        for app in sorted({APP.get(case, case) for case in CASES}):
            shown = subprocess.run([str(Path(build) / "apps" / app / app), "--help"], capture_output=True, text=True)
            if "\nGeneral:\n" not in shown.stdout or "\nOptions:\n" in shown.stdout:
                failures.append(f"{app} --help is not grouped: {shown.stdout[:300]}")
        # The schema itself: it rejects each planted break of a summary that passes it.
        dambreak = json.loads((Path(tmp) / "dambreak" / "first" / "summary.json").read_text())
        if breaks_of_schema(dambreak):
            failures.append("the dambreak summary the planted breaks start from fails the schema already")
        failures += [f"the schema accepted a planted break: {b}" for b in planted_accepted(dambreak)]
        # A run the guard stops: status "failed", pass false, exit 1.
        args = "--mode inlet --re 400 --across 10 --end-time 0.5 --frames 0 --dt-factor 20".split()
        stopped = Path(tmp) / "stopped"
        status, err = run(build, "poiseuille", args, stopped)
        failures += schema_errors("poiseuille", args, stopped, status) if status == 1 else [f"no guard stop: {status}"]
        # A key the app does not know is an error naming it, not a silent default.
        bad = Path(tmp) / "bad.toml"
        bad.write_text((Path(tmp) / "poiseuille" / "first" / "config.toml").read_text() + "gama = 0.5\n")
        status, err = run(build, "poiseuille", ["--config", str(bad)], Path(tmp) / "bad")
        if status == 0 or "gama" not in err:
            failures.append(f"a misspelt key was accepted (exit {status}): {err[-300:]}")
    for f in failures:
        print("FAIL", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
