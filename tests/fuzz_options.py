#!/usr/bin/python3
"""Seeded random sweep over the apps' options (run by ctest): each run must end with a clear error (exit 1 or 105,
a message naming the cause) or a real result (exit 0 or 2 with a summary of at least one step, every number finite,
as many frames on disk as the .pvd lists), never a crash, a hang or a NaN in a summary.

  tests/fuzz_options.py BUILD_DIR [CASES]
"""
import json
import os
import random
import re
import subprocess
import sys
import tempfile
from pathlib import Path

# Each app from a small, quick base run; one or two options at a time take a hostile value.
BASE = {
    "poiseuille": "--mode body-force --across 8 --end-time 0.3 --frames 2",
    "hydrostatic": "--end-time 0.02 --window 0.01 --frames 2",
    "rotating": "--scene couette --across 6 --times 0.01 --frames 2",
    "acoustic": "--size 20 --l0 0.5 --end-time 0.01 --maps 0.005 --frames 2",
    "dambreak": "--end-time 0.02 --frames 2",
    "structure": "--dx 0.004 --end-time 0.01 --frames 2",
    "fsi": "--end-time 0.01 --frames 2",
}
OPTIONS = {
    "poiseuille": ["--re", "--width", "--across", "--length", "--gamma", "--dt-factor", "--nu", "--end-time", "--average",
                   "--profiles", "--frames", "--tolerance", "--shifting", "--compression", "--outlet-buffer", "--solver",
                   "--mode"],
    "hydrostatic": ["--width", "--height", "--dx", "--gamma", "--dt", "--end-time", "--window", "--band", "--frames",
                    "--tolerance", "--solver"],
    "rotating": ["--across", "--omega", "--nu", "--span", "--gamma", "--dt-factor", "--times", "--average", "--frames",
                 "--tolerance", "--agreement", "--symmetry", "--shifting", "--scene", "--model", "--walls"],
    "acoustic": ["--case", "--size", "--l0", "--cfl", "--b", "--amplitude", "--c0", "--rho0", "--u0", "--frequency",
                 "--radius", "--end-time", "--samples", "--maps", "--frames", "--tolerance", "--guard-factor"],
    "dambreak": ["--column", "--dx", "--gamma", "--cfl", "--asymmetry", "--asymmetry-interior-density", "--end-time",
                 "--frames", "--front-speed-tolerance", "--front-shape-tolerance", "--tank-length", "--sensor-height",
                 "--pressure-treatment", "--shifting", "--gradient", "--collision", "--stabilisation-distance",
                 "--restitution", "--solver", "--data", "--particles"],
    "structure": ["--scene", "--dx", "--model", "--radius", "--hourglass", "--cfl", "--end-time", "--sample-interval",
                  "--frames", "--period-tolerance", "--amplitude-tolerance", "--csm3-tolerance", "--data"],
    "fsi": ["--scene", "--dx", "--modulus", "--poisson", "--density", "--cfl", "--relaxation", "--solid-cfl",
            "--end-time", "--frames", "--solver", "--pressure-gradient", "--pressure-treatment", "--wet-walls",
            "--collision", "--asymmetry", "--stabilisation-distance"],
}
# Hostile values and a few ordinary ones (large but legitimate values are left out: a long run is no bug).
VALUES = ["0", "-1", "1", "2", "0.5", "nan", "inf", "-inf", "1e300", "1e-300", "abc", "", "2147483647", "3",
          "0.01,0.02", "0.02,0.01", "eigen-cg:precond=ic,", "cholmod", "both", "fixed", "plain", "hard", "seed",
          "csm3", "linear", "0.002", "gate", "conservative", "true", "false", "hs+hl", "hs+hs", "none"]
NULL_ALLOWED = {"frequency_hz"}  # acoustic: null when the case repeats no pulse
# A small environment, keeping the sanitizers' options (make test-sanitize turns leak detection off).
ENV = {"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin",
       **{k: v for k, v in os.environ.items() if k in ("ASAN_OPTIONS", "UBSAN_OPTIONS", "LSAN_OPTIONS")}}


def numbers(value, key=""):
    if isinstance(value, dict):
        for k, v in value.items():
            yield from numbers(v, k)
    elif isinstance(value, list):
        for v in value:
            yield from numbers(v, key)
    else:
        yield key, value


def check(app, args, proc, out):
    """Returns what is wrong with this run, or None."""
    if proc.returncode < 0:
        return f"killed by signal {-proc.returncode}"
    if proc.returncode == 1 or 100 <= proc.returncode <= 114:  # ours, or CLI11's parse errors
        return None if "error" in proc.stderr.lower() or "must" in proc.stderr or "--" in proc.stderr \
            else f"exit {proc.returncode} without a message"
    if proc.returncode not in (0, 2):
        return f"exit {proc.returncode}"
    if re.search(r"\bnan\b", proc.stdout, re.IGNORECASE):  # a figure the run could not give, printed as NaN
        return "printed nan: " + next(line for line in proc.stdout.splitlines() if re.search(r"\bnan\b", line, re.I))
    summary_file = out / "summary.json"
    if not summary_file.exists():
        return "no summary.json"
    summary = json.loads(summary_file.read_text())
    for key, v in numbers(summary):
        if v is None and key not in NULL_ALLOWED:
            return f"null (NaN?) at {key!r} in summary.json"
    if not summary.get("steps", 0) > 0:
        return "a run of no steps reported " + str(summary.get("status"))
    pvd = list(out.glob("*.pvd"))
    if pvd:
        listed = pvd[0].read_text().count("<DataSet")
        on_disk = len(list((out / "frames").glob("*.vtp")))
        if listed != on_disk:
            return f"{on_disk} frames on disk, {listed} in the .pvd"
    return None


def special_inputs(build, tmp):
    """Paths that are not what an option needs and damaged config files, for every app. Returns the failures."""
    failures, count = [], 0
    env = ENV
    (tmp / "a_file").write_text("a file\n")
    for app in sorted(BASE):
        exe = str(build / "apps" / app / app)
        base = BASE[app].split()
        good = tmp / f"{app}-base"
        proc = subprocess.run([exe, *base, "--out", str(good)], capture_output=True, text=True, timeout=120, env=env)
        if proc.returncode not in (0, 2):
            failures.append(f"{app} {' '.join(base)}: exit {proc.returncode}: {proc.stderr[-300:]}")
            continue
        config = (good / "config.toml").read_text()
        first_key = next(line for line in config.splitlines() if " = " in line)
        # (file text, what the refusal must say; None: the run must succeed)
        configs = [
            (config.replace(first_key, first_key + "\n" + first_key, 1), "cannot redefine existing"),
            ("\ufeff" + config, None),
            (config.replace("\n", "\n\0", 1), "line 2, column 1"),
            ("[section]\n" + config, "[section] is no group of this app's options"),
            (config + first_key.split("=")[0] + "\n", "expected '='"),
            (config + 'solver="auto\n', "Error while parsing string"),
        ]
        cases = [(["--out", "/dev/full"], "not a directory"), (["--out", "/dev/full/x"], "not a directory"),
                 (["--out", ""], "empty"), (["--out", str(tmp / "a_file")], "not a directory")]
        # Every app takes --dim; those whose scenes are 2-D refuse 3 saying so, and take 2.
        cases += [(["--dim", "3", "--out", str(tmp / "d3")],
                   None if app in ("hydrostatic", "dambreak", "rotating") else "this app is 2-D only"),
                  (["--dim", "2", "--out", str(tmp / "d2")], None)]
        if app in ("dambreak", "fsi", "hydrostatic"):  # a probe file that is none, or a TOML file of no probes
            (tmp / "no_probes.toml").write_text("interval = 0.01\n")
            cases += [(["--probes", "/dev/zero", "--out", str(tmp / "p")], "not a regular file"),
                      (["--probes", "", "--out", str(tmp / "p")], "empty"),
                      (["--probes", str(tmp / "a_file"), "--out", str(tmp / "p")], "a_file, line 1"),
                      (["--probes", str(tmp / "no_probes.toml"), "--out", str(tmp / "p")],
                       "probes are listed as [[probe]] tables")]
        if app == "dambreak":
            cases += [(["--write-particles", "/dev/full", "--out", str(tmp / "w")], "not a regular file"),
                      (["--particles", "", "--out", str(tmp / "w")], "empty")]
        for k, (text, said) in enumerate(configs):
            path = good / f"{app}-{k}.toml"  # beside the original: its paths are relative to the file's folder
            path.write_bytes(text.encode("utf-8"))
            cases.append((["--config", str(path), "--out", str(tmp / f"{app}-config-{k}")], said))
        for args, said in cases:
            count += 1
            proc = subprocess.run([exe, *base, *args], capture_output=True, text=True, timeout=120, env=env)
            if said is None and (proc.returncode not in (0, 2) or re.search(r"\bnan\b", proc.stdout, re.I)):
                failures.append(f"{app} {' '.join(args)}: exit {proc.returncode}: {proc.stderr[-300:]}"
                                f"{proc.stdout[-300:]}")
            elif said is not None and (proc.returncode in (0, 2) or said not in proc.stderr):
                failures.append(f"{app} {' '.join(args)}: exit {proc.returncode}, expected {said!r} in "
                                f"{proc.stderr[-300:]!r}")
        if not Path("/dev/full").is_char_device():
            failures.append(f"{app} replaced /dev/full")
    print(f"special paths, --dim, probe files and damaged config files: {count} cases")
    return failures


def main():
    build = Path(sys.argv[1])
    cases = int(sys.argv[2]) if len(sys.argv) > 2 else 60
    rng = random.Random(2026)
    failures, outcomes = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for case in range(cases):
            app = sorted(BASE)[case % len(BASE)]
            words = BASE[app].split()
            options = dict(zip(words[::2], words[1::2]))
            options.update({rng.choice(OPTIONS[app]): rng.choice(VALUES) for _ in range(rng.choice((1, 1, 2)))})
            args = [w for kv in options.items() for w in kv if w is not None]
            out = Path(tmp) / f"run{case}"
            (out / "frames").mkdir(parents=True)
            (out / "frames" / "stale_0099.vtp").write_text("stale")  # a reused --out: must not survive a run
            try:
                proc = subprocess.run([str(build / "apps" / app / app), *args, "--out", str(out)], capture_output=True,
                                      text=True, timeout=120, env=ENV)
                problem = check(app, args, proc, out)
                outcomes[proc.returncode] = outcomes.get(proc.returncode, 0) + 1
            except subprocess.TimeoutExpired:
                problem = "hung (no end within 120 s)"
            if problem:
                failures.append(f"{app} {' '.join(args)}: {problem}")
        failures += special_inputs(build, Path(tmp))
    print("exit codes:", dict(sorted(outcomes.items())))
    for f in failures:
        print("FAIL", f)
    print(f"{cases - len(failures)} passed, {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
