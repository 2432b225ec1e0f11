#!/usr/bin/python3
"""A reproducible sweep of hostile inputs (issue 36's cases and close variants) over the seven apps, mpirun and the
Python module, with each case's outcome classified automatically and counted per surface.

Outcomes (the first five fail the sweep):
  crash              killed by a signal, or stderr holding "terminate called", "munmap_chunk", "Segmentation fault",
                     "core dumped", "Aborted", a traceback ending in SystemError or an exception not the library's
  hang               no exit within TIMEOUT seconds (the process group and session are killed)
  garbage            exit 0 or 2 with NaN/null in summary.json, a completed run with no fluid left, NaN in the arrays
                     Python returned, /dev/full no longer a device, summaries that differ between 1 and 2 threads
  silent acceptance  an input marked bad that ran (exit 0/2, or returned in Python) without a word on stderr, or a
                     run that ran without saying what the case requires it to say
  unclear message    a refusal with no text or with a known-unclear text (UNCLEAR), or "nan" in a run's stdout
  refused clearly    non-zero exit (or ValueError, TypeError, RuntimeError, MemoryError, SolverError,
                     SimulationError) with a message
  ran                a good or borderline input ("may"/"run" cases) that ran (exit 0/2, or returned in Python)
Two further outcomes fail it too, should they occur: "wrongly refused" (an input that must run was refused) and
"warned, ran" (a bad input that ran with a warning on stderr instead of being refused).

Each case runs in a temporary directory, in a session of its own (killed whole on a hang), with at most
MEMORY_LIMIT of address space per process, so that an input asking for unbounded memory fails alone. Python cases
run each in a fresh /usr/bin/python3, so that a crash of the interpreter is seen as one.

  scripts/hostile_sweep.py [--verbose] BUILD_DIR     (e.g. build/test; exit 1 if any case is not clean;
                                                     --verbose prints the clean cases too)
"""
import json
import math
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TIMEOUT = 60  # seconds before a case counts as hung (mpirun cases too)
MEMORY_LIMIT = 8 << 30  # bytes of address space per process of a case
PYTHON = "/usr/bin/python3"  # Debian's: the module's ABI, NumPy and SciPy
OUTCOMES = ["crash", "hang", "garbage", "silent acceptance", "unclear message", "refused clearly", "ran"]
EXTRA_OUTCOMES = ["wrongly refused", "warned, ran"]
CLEAN = {"refused clearly", "ran"}
VERBOSE = False
CRASH = ["terminate called", "munmap_chunk", "Segmentation fault", "core dumped", "Aborted", "double free",
         "free(): invalid", "corrupted size", "stack smashing", "exited on signal", "AddressSanitizer"]
UNCLEAR = [r"INI was not able to parse", r"Unable to cast", r"bad_alloc", r"AttributeError",
           r"fill_rectangle: rectangle is empty", r"filesystem error", r"basic_string", r"\bsto[id]\b",
           r"vector::_M", r"\bout_of_range\b", r"diagonal entry <= 0.*\bnan\b"]  # regular expressions
LIBRARY_EXCEPTIONS = {"ValueError", "TypeError", "RuntimeError", "MemoryError", "SolverError", "SimulationError"}
NULL_ALLOWED = {"frequency_hz"}  # acoustic: null when the case repeats no pulse (as tests/fuzz_options.py)

# Each app from a small, quick run (tests/fuzz_options.py's bases, fewer frames).
BASE = {
    "poiseuille": "--mode body-force --across 8 --end-time 0.05 --frames 0",
    "hydrostatic": "--end-time 0.02 --window 0.01 --frames 0",
    "rotating": "--scene couette --across 6 --times 0.01 --frames 0",
    "acoustic": "--size 20 --l0 0.5 --end-time 0.01 --maps 0.005 --frames 0",
    "dambreak": "--end-time 0.01 --frames 0",
    "structure": "--dx 0.004 --end-time 0.01 --frames 0",
    "fsi": "--end-time 0.005 --frames 0",
}
# Under mpirun the body-force channel is periodic, which runs serially only: the inlet channel instead.
MPI_BASE = dict(BASE, poiseuille="--mode inlet --across 8 --end-time 0.02 --frames 0")
APPS = sorted(BASE)
CLASSIC = ["--column", "classic", "--dx", "0.0146"]


# ---------------------------------------------------------------------------------------------------------------------
# Running a case


def limit_memory():
    """A hostile input may ask for memory without bound (a config file read from /dev/zero): each case gets at most
    MEMORY_LIMIT of address space, so that it fails alone instead of the machine running out."""
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def run_process(argv, env, cwd):
    """Runs argv in its own session; returns (exit status or None if hung, stdout, stderr, seconds)."""
    start = time.monotonic()
    proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                            cwd=cwd, start_new_session=True, preexec_fn=limit_memory)
    try:
        out, err = proc.communicate(timeout=TIMEOUT)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        kill_session(proc.pid)
        out, err = proc.communicate()
        code = None
    kill_session(proc.pid)  # anything the case left behind (an orphaned rank)
    return code, out.decode(errors="replace"), err.decode(errors="replace"), time.monotonic() - start


def kill_session(sid):
    """Kills every process of the session this sweep started for one case (the case's process group and any
    process that left it), by id."""
    try:
        os.killpg(sid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[3]) == sid:  # the session id
                try:
                    os.kill(int(entry.name), signal.SIGKILL)
                except ProcessLookupError:
                    pass


def replaced(text, old, new):
    """text with old replaced by new; old must be there (else the case would test nothing)."""
    if old not in text:
        raise ValueError(f"{old!r} is not in the text to edit")
    return text.replace(old, new)


def gist(text):
    """The line of an app's stderr that says why (its first 'error' or 'warning' line), else its first line."""
    lines = [line.strip() for line in text.splitlines() if line.strip() and not line.startswith("---")]
    return next((line for line in lines if re.search(r"error|warning", line, re.I)), lines[0] if lines else "")[:300]


def tail(text, lines=6):
    kept = [line for line in text.strip().splitlines() if line.strip()][-lines:]
    return "\n".join(line[:300] for line in kept)


def bad_numbers(value, key=""):
    """The keys of a summary that hold null, NaN or Inf."""
    if isinstance(value, dict):
        return [k for kk, v in value.items() for k in bad_numbers(v, kk)]
    if isinstance(value, list):
        return [k for v in value for k in bad_numbers(v, key)]
    if value is None and key not in NULL_ALLOWED or isinstance(value, float) and not math.isfinite(value):
        return [key]
    return []


def summary_problem(out):
    """What is wrong with the summary.json of a run that ran, or None."""
    path = Path(out) / "summary.json" if out else None
    if path is None or not path.exists():
        return None
    try:
        summary = json.loads(path.read_text())
    except ValueError as e:
        return f"summary.json is not JSON: {e}"
    bad = bad_numbers(summary)
    if bad:
        return f"null/NaN in summary.json at {sorted(set(bad))}"
    fluid = summary.get("particles", {}).get("fluid") if isinstance(summary.get("particles"), dict) else None
    removed = summary.get("checks", {}).get("fluid_removed_as_spray_count", 0)
    if summary.get("status") in ("completed", "passed") and fluid is not None and fluid - removed <= 0:
        return f"status {summary['status']} with {fluid - removed} fluid particles left"
    return None


def classify_app(case, code, out, err, out_dir):
    """The outcome of an app's run and the reason."""
    expect, say = case["expect"], case.get("say")
    if code is None:
        return "hang", f"no exit within {TIMEOUT} s"
    if code < 0:
        return "crash", f"killed by signal {-code}"
    crash = next((p for p in CRASH if p in err or p in out), None)
    if crash:
        return "crash", f"exit {code}, {crash!r} in the output"
    if case.get("after"):
        problem = case["after"]()
        if problem:
            return "garbage", problem
    if code in (0, 2):
        problem = summary_problem(out_dir)
        if problem:
            return "garbage", f"exit {code}: {problem}"
        nan_line = next((line for line in out.splitlines() if re.search(r"\bnan\b", line, re.I)), None)
        if nan_line:
            return "unclear message", f"exit {code}, printed nan: {nan_line.strip()}"
        if expect == "bad":
            return ("warned, ran", f"exit {code}") if err.strip() else ("silent acceptance", f"exit {code}")
        if say and say not in err:
            return "silent acceptance", f"exit {code} without {say!r} on stderr"
        return "ran", f"exit {code}"
    text = (err + out).strip() if case.get("mpi") else err.strip()
    if not text:
        return "unclear message", f"exit {code} without a message"
    unclear = next((p for p in UNCLEAR if re.search(p, text, re.I | re.S)), None)
    if unclear:
        return "unclear message", f"exit {code}: {unclear!r}"
    if say and say not in text:
        return "unclear message", f"exit {code} without {say!r}"
    if expect == "run":
        return "wrongly refused", f"exit {code}"
    return "refused clearly", f"exit {code}"


# The Python side: each case a statement in a fresh interpreter that sets `result`; the wrapper reports what it raised
# or whether what it returned holds NaN, as one JSON line.
PY_PRELUDE = r'''
import json, math, sys
import numpy as np, scipy.sparse
import sparsemps as sps

L0 = 0.02
DOMAIN = (-0.15, 0.35, -0.15, 0.4)
def tank():
    return sps.Particles().fill_rectangle((0, 0, 0.1, 0.1), L0).add_rectangle_walls((0, 0, 0.2, 0.2), L0,
                                                                                    sides="left|right|bottom")
def sim(**fields):
    return sps.Simulation(tank(), DOMAIN, l0=L0, fy=-9.81, dt_max=1e-3, **fields)
def simulation(domain, particles=None, **fields):  # sps.Simulation(particles, domain, ...) of the tank by default
    fields = dict(dict(l0=L0, dt_max=1e-3), **fields)
    return sps.Simulation(tank() if particles is None else particles, domain, **fields)
def matrix(n=10, seed=36):
    rng = np.random.default_rng(seed)
    a = scipy.sparse.random(n, n, density=0.3, random_state=seed, format="csr")
    a = a + a.T + scipy.sparse.identity(n) * (2 * n)
    return scipy.sparse.csr_matrix(a), rng.standard_normal(n)
def has_nan(v, depth=0):
    if depth > 3 or v is None or isinstance(v, (str, bytes, bool)):
        return False
    if isinstance(v, (float, int)):
        return not math.isfinite(v)
    if isinstance(v, np.ndarray):
        return v.dtype.kind in "fc" and not np.isfinite(v).all()
    if scipy.sparse.issparse(v):
        return has_nan(v.data)
    if isinstance(v, (tuple, list)):
        return any(has_nan(x, depth + 1) for x in v)
    names = ("matrix", "rhs", "x", "y", "u", "v", "p", "relative_residual", "particles", "time", "solve")
    return any(has_nan(getattr(v, n, None), depth + 1) for n in names if n in dir(v))
'''
PY_WRAPPER = r'''
try:
    result = None
{body}
    print("@@" + json.dumps({{"returned": True, "nan": bool(has_nan(result))}}))
except Exception as e:
    print("@@" + json.dumps({{"raised": type(e).__name__, "module": type(e).__module__, "message": str(e)}}))
'''


def python_source(body):
    return PY_PRELUDE + PY_WRAPPER.format(body="\n".join("    " + line for line in body.strip().splitlines()))


def classify_python(case, code, out, err):
    expect, say = case["expect"], case.get("say")
    if code is None:
        return "hang", f"no exit within {TIMEOUT} s"
    if code < 0:
        return "crash", f"interpreter killed by signal {-code}"
    crash = next((p for p in CRASH if p in err), None)
    if crash:
        return "crash", f"{crash!r} on stderr"
    line = next((line[2:] for line in out.splitlines() if line.startswith("@@")), None)
    if line is None:
        last = err.strip().splitlines()[-1] if err.strip() else f"exit {code}"
        return "crash", f"the interpreter died: {last}"
    report = json.loads(line)
    if "returned" in report:
        if report["nan"]:
            return "garbage", "returned arrays holding NaN or Inf"
        if expect == "bad":
            return "silent acceptance", "returned normally"
        return "ran", "returned"
    name, message = report["raised"], report["message"]
    what = f"{report['module']}.{name}: {message[:300]}"
    if name == "SystemError":
        return "crash", what
    if name not in LIBRARY_EXCEPTIONS:
        return "unclear message", what
    if not message.strip():
        return "unclear message", f"{name} without a message"
    unclear = next((p for p in UNCLEAR if re.search(p, message, re.I | re.S)), None)
    if unclear:
        return "unclear message", f"{unclear!r}: {what}"
    if say and say not in message:
        return "unclear message", f"without {say!r}: {what}"
    if expect == "run":
        return "wrongly refused", what
    return "refused clearly", what


# ---------------------------------------------------------------------------------------------------------------------
# The cases: (surface, expect, label, what to run, options). expect: "bad" must be refused, "may" may run or be refused,
# "run" must run. What to run: app(...) or py(...). Options: say (text the message or the run's stderr must hold),
# after (a check once it ended: garbage if it returns a reason).


class Sweep:
    def __init__(self, build, tmp):
        self.build, self.tmp = Path(build).resolve(), Path(tmp)
        self.runs = 0
        self.env = dict(os.environ, OMP_NUM_THREADS="1")
        self.mpi_env = dict(self.env, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
        self.py_env = dict(self.env, PYTHONPATH=str(self.build / "python"))

    def exe(self, name):
        return str(self.build / "apps" / name / name)

    def new_out(self):
        self.runs += 1
        return str(self.tmp / "runs" / f"r{self.runs:03d}")

    def app(self, name, *args, base=True, np_=None, out=True, threads=1):
        """An app's command: its base options (unless base=False), args, and a fresh --out unless args give one."""
        argv = [self.exe(name), *((MPI_BASE if np_ else BASE)[name].split() if base else []), *args]
        out_dir = None
        if out and "--out" not in args:
            out_dir = self.new_out()
            argv += ["--out", out_dir]
        if np_:
            argv = ["mpirun", "--oversubscribe", "-np", str(np_), *argv]
        return {"argv": argv, "out": out_dir, "mpi": np_, "threads": threads}

    def run(self, what):
        if "python" in what:
            return run_process([PYTHON, "-c", python_source(what["python"])], self.py_env, self.tmp)
        env = self.mpi_env if what["mpi"] else dict(self.env, OMP_NUM_THREADS=str(what["threads"]))
        return run_process(what["argv"], env, self.tmp)

    # --- what the cases need, made once -------------------------------------------------------------------------

    def prepare(self):
        t = self.tmp
        (t / "runs").mkdir()
        (t / "a_file").write_text("a file, not a folder\n")
        (t / "a_dir").mkdir()
        os.mkfifo(t / "a_fifo")
        os.symlink("/dev/full", t / "link_to_full")
        os.mkfifo(t / "leftover.csv.tmp")  # a temporary file's name taken by a FIFO
        self.configs = {}
        for name in APPS:  # each app's own config.toml, from a short run
            out = t / f"{name}-base"
            code, _, err, _ = run_process([self.exe(name), *BASE[name].split(), "--out", str(out)], self.env, t)
            if code not in (0, 2):
                sys.exit(f"{name} {BASE[name]}: exit {code}: {tail(err)}")
            self.configs[name] = (out / "config.toml").read_text()
        code, out, err, _ = run_process([self.exe("dambreak"), *CLASSIC, "--write-particles", str(t / "classic.csv")],
                                        self.env, t)
        if code != 0:
            sys.exit(f"dambreak --write-particles: exit {code}: {tail(err)}")
        out = t / "frames-run"  # a run's .vtp frame, whole
        code, _, err, _ = run_process([self.exe("dambreak"), *CLASSIC, "--end-time", "0.01", "--frames", "1",
                                       "--out", str(out)], self.env, t)
        frames = sorted((out / "frames").glob("*.vtp")) if code in (0, 2) else []
        if not frames:
            sys.exit(f"dambreak frames run: exit {code}: {tail(err)}")
        self.frame = frames[-1].read_bytes()
        code, _, err, _ = run_process([self.exe("poiseuille"), *BASE["poiseuille"].replace("--frames 0", "--frames 1")
                                      .split(), "--out", str(t / "poiseuille-frames")], self.env, t)
        self.poiseuille_frame = sorted((t / "poiseuille-frames" / "frames").glob("*.vtp"))[-1]

    def write(self, name, data):
        path = self.tmp / name
        path.write_bytes(data.encode() if isinstance(data, str) else data)
        return str(path)

    def edited_particles(self, name, kind=None, column=None, value=None, scale=1.0):
        """The classic column's particle file with the first `kind` particle's column set to value, or every position
        scaled (tests/particle_files.py)."""
        lines = (self.tmp / "classic.csv").read_text().splitlines()
        header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
        names = lines[header].split(",")
        rows, done = [], False
        for line in lines[header + 1:]:
            row = dict(zip(names, line.split(",")))
            if not done and row["kind"] == kind and column:
                row[column], done = value, True
            row["x"], row["y"] = repr(float(row["x"]) * scale), repr(float(row["y"]) * scale)
            rows.append(",".join(row[n] for n in names))
        return self.write(name, "\n".join(lines[:header + 1] + rows) + "\n")

    def config_variants(self, name):
        """(label, expect, file text, say) of damaged copies of an app's own config.toml."""
        text = self.configs[name]
        lines = text.splitlines()
        keys = [k for k, line in enumerate(lines) if "=" in line and not line.startswith("#")]

        def line_set(k, new):  # the file with line k replaced
            return "\n".join(lines[:k] + [new] + lines[k + 1:]) + "\n"
        first, last = keys[0], keys[-1]
        string = next(k for k in keys if lines[k].split("=", 1)[1].startswith('"'))
        switch = next((k for k in keys if lines[k].split("=", 1)[1] in ("true", "false")), None)
        repeated = "gamma=0.5" if name == "dambreak" else lines[first]
        variants = [
            ("repeated key", "bad", text + repeated + "\n", "is set again"),
            ("malformed line", "bad", text + "this line is not a key and a value\n", "expected 'key = value'"),
            ("empty key= line", "bad", line_set(last, lines[last].split("=")[0] + "="), None),
            ("unterminated string", "bad", line_set(string, lines[string][:-1]), "is not closed"),
            ("section [x]", "bad", "[x]\n" + text, "sections"),
            ("BOM", "run", "\ufeff" + text, None),
            ("NUL byte", "bad", line_set(first, lines[first][:2] + "\0" + lines[first][2:]), "NUL"),
            ("unknown key", "bad", text + "gama=0.5\n", "is not an option"),
        ]
        if switch is not None:
            variants.append(("switch given 2", "bad", line_set(switch, lines[switch].split("=")[0] + "=2"),
                             "is a switch"))
        else:  # hydrostatic and structure have no switch: a number given a switch's value instead
            frames = next(k for k in keys if lines[k].startswith("frames="))
            variants.append(("frames=true (no switch to give 2)", "bad", line_set(frames, "frames=true"), None))
        return variants

    def cases(self):
        t, app = self.tmp, self.app
        cases = []

        def add(surface, expect, label, what, **options):
            cases.append((surface, expect, label, what, options))

        def py(body):
            return {"python": body}

        def still_a(path, test, kind):  # an `after` check: the path must still be what it was
            return lambda: None if test(Path(path)) else f"{path} is no longer a {kind}"
        full_intact = still_a("/dev/full", Path.is_char_device, "character device")
        fifo_intact = still_a(t / "a_fifo", Path.is_fifo, "FIFO")
        leftover_intact = still_a(t / "leftover.csv.tmp", Path.is_fifo, "FIFO")

        # --- dambreak --write-particles: paths that are not a file to write; /dev/full must stay a device
        for label, path, check, say in [
                ("/dev/full", "/dev/full", full_intact, "not a regular file"),
                ("a FIFO", str(t / "a_fifo"), fifo_intact, "not a regular file"),
                ("a directory", str(t / "a_dir"), None, "not a regular file"),
                ("''", "", None, "empty"),
                ("/dev/null", "/dev/null", None, "not a regular file"),
                ("a link to /dev/full", str(t / "link_to_full"), full_intact, "not a regular file"),
                ("below a file", str(t / "a_file" / "p.csv"), None, None),
                ("below /dev/full", "/dev/full/p.csv", full_intact, None),
                ("in /proc", "/proc/sparsemps-p.csv", None, None),
                ("its .tmp name a FIFO", str(t / "leftover.csv"), leftover_intact, "FIFO")]:
            add("output paths", "bad", f"dambreak --write-particles {label}",
                app("dambreak", *CLASSIC, "--write-particles", path, base=False, out=False), after=check, say=say)
        add("output paths", "may", "dambreak --write-particles in a missing folder (made)",
            app("dambreak", *CLASSIC, "--write-particles", str(t / "missing" / "p.csv"), base=False, out=False))
        add("output paths", "run", "dambreak --write-particles a new file",
            app("dambreak", *CLASSIC, "--write-particles", str(t / "written.csv"), base=False, out=False))

        # --- --out on every app: serially, and under mpirun for dambreak and poiseuille
        outs = [("/dev/full/x", "/dev/full/x", "/dev/full is not a directory"),
                ("/proc/sparsemps-x", "/proc/sparsemps-x", "/proc/sparsemps-x"),
                ("a file", str(t / "a_file"), "not a directory"), ("''", "", "empty"),
                ("below a file", str(t / "a_file" / "x"), "not a directory")]
        for name in APPS:
            for label, path, say in outs:
                add("output paths", "bad", f"{name} --out {label}", app(name, "--out", path), after=full_intact,
                    say=say)
        for name in ("dambreak", "poiseuille"):
            for np_ in (2, 3):
                for label, path, say in outs[:4]:
                    add("mpirun", "bad", f"mpirun -np {np_} {name} --out {label}",
                        app(name, "--out", path, np_=np_), after=full_intact, say=say)

        # --- --particles '' and its variants
        empty = self.write("particles-empty.toml", 'particles=""\n')
        add("particle files", "bad", "dambreak --particles ''", app("dambreak", "--particles", ""), say="empty")
        add("config files", "bad", "dambreak --config with particles=\"\"", app("dambreak", "--config", empty),
            say="empty")
        for np_ in (2, 3):
            add("mpirun", "bad", f"mpirun -np {np_} dambreak --particles ''",
                app("dambreak", "--particles", "", np_=np_), say="empty")
        add("mpirun", "bad", "mpirun -np 2 dambreak --config with particles=\"\"",
            app("dambreak", "--config", empty, np_=2), say="empty")
        add("particle files", "bad", "dambreak --particles a directory",
            app("dambreak", "--particles", str(t / "a_dir")))
        add("particle files", "bad", "dambreak --particles a missing file",
            app("dambreak", "--particles", str(t / "missing.csv")))
        add("particle files", "bad", "dambreak --particles /dev/null", app("dambreak", "--particles", "/dev/null"))

        # --- the inlet channel's ghost pool under mpirun (a clear failure during the run, or a run)
        for np_ in (2, 3):
            add("mpirun", "may", f"mpirun -np {np_} poiseuille inlet --dt-factor 50",
                app("poiseuille", "--mode", "inlet", "--across", "8", "--channel-length", "4", "--station", "2",
                    "--end-time", "0.2", "--dt-factor", "50", base=False, np_=np_))

        # --- dambreak --particles: damaged and extreme particle files
        classic = str(t / "classic.csv")
        particle_files = [
            ("the classic column's file", "run", classic, None),
            ("scaled by 1e-9", "bad", self.edited_particles("tiny.csv", scale=1e-9), None),
            ("scaled by 1e-3", "may", self.edited_particles("small.csv", scale=1e-3), None),
            ("a fluid particle at u = 1e10", "bad", self.edited_particles("u1e10.csv", "fluid", "u", "1e10"), None),
            ("a fluid particle at u = 1e300", "bad", self.edited_particles("u1e300.csv", "fluid", "u", "1e300"), None),
            ("a fluid particle at u = nan", "bad", self.edited_particles("unan.csv", "fluid", "u", "nan"), None),
            ("a fluid particle at p = 1e300", "bad", self.edited_particles("p1e300.csv", "fluid", "p", "1e300"), None),
            ("a fluid particle at p = -1e300", "bad", self.edited_particles("pm1e300.csv", "fluid", "p", "-1e300"),
             None),
            ("a wall row at x = 1e300", "bad", self.edited_particles("wall1e300.csv", "wall", "x", "1e300"), None),
            ("a wall row at y = -1e300", "bad", self.edited_particles("wally.csv", "wall", "y", "-1e300"), None),
            ("a fluid particle far outside the tank (x = 10)", "bad",
             self.edited_particles("far.csv", "fluid", "x", "10"), None),
            ("a fluid particle at x = 1e300", "bad", self.edited_particles("far300.csv", "fluid", "x", "1e300"), None),
            ("a fluid particle above the tank (y = 5)", "bad", self.edited_particles("above.csv", "fluid", "y", "5"),
             None),
            ("a fluid particle of kind 'ghost'", "bad", self.edited_particles("ghost.csv", "fluid", "kind", "ghost"),
             None),
            ("a whole frame (.vtp)", "run", self.write("whole.vtp", self.frame), None),
            ("a frame missing its last 30 bytes", "bad", self.write("cut30.vtp", self.frame[:-30]), None),
            ("a frame missing its last 28 bytes", "bad", self.write("cut28.vtp", self.frame[:-28]), None),
            ("a frame missing its last byte", "may", self.write("cut1.vtp", self.frame[:-1]), None),
            ("a frame missing its last 100 bytes", "bad", self.write("cut100.vtp", self.frame[:-100]), None),
            ("a frame cut in half", "bad", self.write("half.vtp", self.frame[:len(self.frame) // 2]), None),
            ("a frame with a byte in its data flipped", "may",
             self.write("flipped.vtp", self.frame[:-200] + bytes([self.frame[-200] ^ 0xff]) + self.frame[-199:]),
             None),
            ("an empty .vtp", "bad", self.write("empty.vtp", b""), None),
            ("an empty .csv", "bad", self.write("empty.csv", b""), None),
            ("a header only", "bad", self.write("header.csv", "x,y,kind\n"), None),
            ("poiseuille's frame", "may", str(self.poiseuille_frame), None),
        ]
        for label, expect, path, say in particle_files:
            add("particle files", expect, f"dambreak --particles {label}",
                app("dambreak", "--particles", path, "--end-time", "0.01", base=False), say=say)
        add("particle files", "bad", "dambreak --column seed --particles classic.csv",
            app("dambreak", "--column", "seed", "--particles", classic), say="--column")
        add("particle files", "bad", "dambreak --particles classic.csv --dx 0.01",
            app("dambreak", "--particles", classic, "--dx", "0.01"))
        for np_ in (2, 3):
            add("mpirun", "bad", f"mpirun -np {np_} dambreak --particles (a fluid particle at u = 1e10)",
                app("dambreak", "--particles", str(t / "u1e10.csv"), np_=np_))
        add("mpirun", "bad", "mpirun -np 2 dambreak --particles (a fluid particle far outside the tank)",
            app("dambreak", "--particles", str(t / "far.csv"), np_=2))
        add("mpirun", "bad", "mpirun -np 2 dambreak --particles (a frame missing its last 28 bytes)",
            app("dambreak", "--particles", str(t / "cut28.vtp"), np_=2))

        # --- dambreak scene options
        for label, expect, args in [("--column classic --dx 1", "bad", ["--column", "classic", "--dx", "1"]),
                                    ("--column classic --dx 0.037", "bad", ["--column", "classic", "--dx", "0.037"]),
                                    ("--column classic --dx 0.0365", "may", ["--column", "classic", "--dx", "0.0365"]),
                                    ("--column classic --dx 1e-300", "bad", ["--column", "classic", "--dx", "1e-300"]),
                                    ("--column seed --dx 1", "bad", ["--column", "seed", "--dx", "1"]),
                                    ("--column nonsense", "bad", ["--column", "nonsense"]),
                                    ("--wet-walls=2", "bad", ["--wet-walls=2"]),
                                    ("--wet-walls=1", "bad", ["--wet-walls=1"]),
                                    ("--wet-walls=", "bad", ["--wet-walls="]),
                                    ("--wet-walls=true", "run", ["--wet-walls=true"]),
                                    ("--wet-walls=false", "run", ["--wet-walls=false"])]:
            add("dambreak options", expect, f"dambreak {label}", app("dambreak", *args))

        # --- fsi and structure options
        for label, expect, name, args in [("fsi --wet-walls ''", "bad", "fsi", ["--wet-walls", ""]),
                                          ("fsi --wet-walls 2", "bad", "fsi", ["--wet-walls", "2"]),
                                          ("fsi --wet-walls yes", "bad", "fsi", ["--wet-walls", "yes"]),
                                          ("fsi --wet-walls true", "run", "fsi", ["--wet-walls", "true"]),
                                          ("fsi --rigid=2", "bad", "fsi", ["--rigid=2"]),
                                          ("fsi --scene gate --dx 1", "bad", "fsi", ["--scene", "gate", "--dx", "1"]),
                                          ("structure --dx 0.003", "bad", "structure", ["--dx", "0.003"]),
                                          ("structure --scene nonsense", "bad", "structure", ["--scene", "nonsense"]),
                                          ("poiseuille --implicit-viscosity=2", "bad", "poiseuille",
                                           ["--implicit-viscosity=2"]),
                                          ("acoustic --no-maps=2", "bad", "acoustic", ["--no-maps=2"]),
                                          ("rotating --lattice-reference=2", "bad", "rotating",
                                           ["--lattice-reference=2"])]:
            surface = "fsi/structure options" if name in ("fsi", "structure") else "switches"
            add(surface, expect, label, app(name, *args))

        # --- frames, --export-ppe and runs shorter than what they report
        forty = ["--end-time", "0.024"]  # the default column: dt 6.1e-4 s, 40 steps
        for label, expect, args, say in [("--export-ppe 5000 on 40 steps", "may", ["--export-ppe", "5000"],
                                          "--export-ppe 5000"),
                                         ("--export-ppe 1,5000 on 40 steps", "may", ["--export-ppe", "1,5000"], "5000"),
                                         ("--export-ppe 41 on 40 steps", "may", ["--export-ppe", "41"], "41"),
                                         ("--export-ppe 40 on 40 steps", "run", ["--export-ppe", "40"], None),
                                         ("--export-ppe 0", "bad", ["--export-ppe", "0"], None),
                                         ("--export-ppe -1", "bad", ["--export-ppe", "-1"], None),
                                         ("--export-ppe abc", "bad", ["--export-ppe", "abc"], None),
                                         ("--export-ppe 99999999999", "bad", ["--export-ppe", "99999999999"], None),
                                         ("--frames -1", "bad", ["--frames", "-1"], None),
                                         ("--frames 1.5", "bad", ["--frames", "1.5"], None),
                                         ("--frames 2147483648", "bad", ["--frames", "2147483648"], None),
                                         ("--frames 1000 on 40 steps", "may", ["--frames", "1000"], None)]:
            add("frames", expect, f"dambreak {label}", app("dambreak", *args, *forty, base=False), say=say)
        add("mpirun", "bad", "mpirun -np 2 dambreak --export-ppe 3",
            app("dambreak", "--export-ppe", "3", np_=2), say="one process")
        for label, name, args in [("structure plate shorter than its period", "structure",
                                   ["--dx", "0.004", "--end-time", "0.05", "--frames", "0"]),
                                  ("structure plate of one sample", "structure",
                                   ["--dx", "0.004", "--end-time", "0.0005", "--frames", "0"]),
                                  ("structure csm3 shorter than its period", "structure",
                                   ["--scene", "csm3", "--end-time", "0.02", "--frames", "0"]),
                                  ("dambreak before the experiments' first point", "dambreak",
                                   ["--end-time", "0.005", "--frames", "0"]),
                                  ("fsi plate of a few steps", "fsi", ["--end-time", "0.002", "--frames", "0"]),
                                  ("poiseuille shorter than its averaging window", "poiseuille",
                                   ["--mode", "body-force", "--across", "8", "--end-time", "0.01", "--frames", "0"])]:
            add("frames", "run", label, app(name, *args, base=False))

        # --- --config files on every app
        for name in APPS:
            for label, expect, text, say in self.config_variants(name):
                path = self.write(f"{name}-{re.sub(r'[^a-z0-9]+', '-', label.lower())}.toml", text)
                # the file alone (it holds every option of the base run): nothing on the command line overrides it
                add("config files", expect, f"{name} --config ({label})", app(name, "--config", path, base=False),
                    say=say)
        text = self.configs["dambreak"]
        for label, expect, path in [("CRLF line ends", "may", self.write("crlf.toml", text.replace("\n", "\r\n"))),
                                    ("an empty file", "run", self.write("empty.toml", "")),
                                    ("gamma=nan", "bad", self.write("gnan.toml", replaced(text, "gamma=0.01",
                                                                                              "gamma=nan"))),
                                    ("gamma=1e999", "bad", self.write("g999.toml", replaced(text, "gamma=0.01",
                                                                                              "gamma=1e999"))),
                                    ("a directory", "bad", str(t / "a_dir")),
                                    ("a missing file", "bad", str(t / "missing.toml")),
                                    ("/dev/zero", "bad", "/dev/zero"),
                                    ("a FIFO no one writes", "bad", str(t / "a_fifo")),
                                    ("''", "bad", "")]:
            add("config files", expect, f"dambreak --config {label}", app("dambreak", "--config", path))
        add("config files", "may", "dambreak --config (gamma=nan) --gamma 0.01",
            app("dambreak", "--config", str(t / "gnan.toml"), "--gamma", "0.01"))
        path = self.write("mpi-repeated.toml", text + "gamma=0.5\n")
        for np_ in (2, 3):
            add("mpirun", "bad", f"mpirun -np {np_} dambreak --config (repeated key)",
                app("dambreak", "--config", path, np_=np_), say="is set again")

        # --- the Python module, each case in its own interpreter
        python_cases = [
            ("solve: CSR with indptr[2] = 100", "bad", "A, b = matrix(); A.indptr[2] = 100\nresult = sps.solve(A, b)",
             "indptr"),
            ("solve: CSR with indptr[2] = -1", "bad", "A, b = matrix(); A.indptr[2] = -1\nresult = sps.solve(A, b)",
             "indptr"),
            ("solve: CSR with indices[0] = 1000", "bad",
             "A, b = matrix(); A.indices[0] = 1000\nresult = sps.solve(A, b)", "indices"),
            ("solve: CSR with data cut short", "bad",
             "A, b = matrix(); A.data = A.data[:-3]\nresult = sps.solve(A, b)", "data"),
            ("solve: CSC with indptr[2] = 100", "bad",
             "A, b = matrix(); A = A.tocsc(); A.indptr[2] = 100\nresult = sps.solve(A, b)", "indptr"),
            ("solve: COO with row[0] = 99", "bad", "A, b = matrix(); A = A.tocoo(); A.row[0] = 99\n"
             "result = sps.solve(A, b)", None),
            ("solve(A, 1.0)", "bad", "A, b = matrix()\nresult = sps.solve(A, 1.0)", None),
            ("solve(A, b of 9 entries)", "bad", "A, b = matrix()\nresult = sps.solve(A, b[:-1])", None),
            ("solve(A, b as a column)", "may", "A, b = matrix()\nresult = sps.solve(A, b.reshape(-1, 1))", None),
            ("solve(A, b holding NaN)", "bad", "A, b = matrix(); b[3] = np.nan\nresult = sps.solve(A, b)", None),
            ("solve(A, b) with x0 all NaN", "may", "A, b = matrix()\nresult = sps.solve(A, b, x0=np.full(10, np.nan))",
             None),
            ("solve of a 10 x 10 SPD matrix", "run", "A, b = matrix()\nresult = sps.solve(A, b, 'eigen-cg')", None),
            ("solve(None, b)", "bad", "A, b = matrix()\nresult = sps.solve(None, b)", None),
            ("solve(A, b, 'no-such-solver')", "bad", "A, b = matrix()\nresult = sps.solve(A, b, 'no-such-solver')",
             None),
        ]
        for spec in ("hypre-pcg", "eigen-cg", "cholmod", "hypre-amg"):
            python_cases.append((f"{spec} on a matrix with a NaN diagonal", "bad",
                                 f"A, b = matrix(); A[1, 1] = np.nan\nresult = sps.solve(A, b, '{spec}')", "NaN"))
        python_cases.append(("hypre-pcg on a matrix with an Inf diagonal", "bad",
                             "A, b = matrix(); A[1, 1] = np.inf\nresult = sps.solve(A, b, 'hypre-pcg')", "Inf"))
        python_cases.append(("hypre-pcg on a matrix with a negative diagonal", "bad",
                             "A, b = matrix(); A[1, 1] = -5\nresult = sps.solve(A, b, 'hypre-pcg')", None))
        ppe = "p = tank(); x, y, kind = p.x, p.y, p.kind; z = np.zeros_like(x)\n"
        python_cases += [
            ("assemble_ppe(radius_laplacian=1e6)", "bad",
             "result = sps.assemble_ppe(tank(), dt=1e-3, l0=0.02, radius_laplacian=1e6)", "radius_laplacian"),
            ("assemble_ppe(radius_laplacian=0.5)", "bad",
             "result = sps.assemble_ppe(tank(), dt=1e-3, l0=0.02, radius_laplacian=0.5)", "radius_laplacian"),
            ("assemble_ppe(radius_gradient=nan)", "bad",
             "result = sps.assemble_ppe(tank(), dt=1e-3, l0=0.02, radius_gradient=float('nan'))", None),
            ("assemble_ppe(dt=nan)", "bad", "result = sps.assemble_ppe(tank(), dt=float('nan'), l0=0.02)", None),
            ("assemble_ppe(dt=0)", "bad", "result = sps.assemble_ppe(tank(), dt=0.0, l0=0.02)", None),
            ("assemble_ppe(l0=-0.02)", "bad", "result = sps.assemble_ppe(tank(), dt=1e-3, l0=-0.02)", None),
            ("assemble_ppe with one NaN velocity", "bad",
             ppe + "u = z.copy(); u[3] = np.nan\nresult = sps.assemble_ppe(x, y, u, z, kind, dt=1e-3, l0=L0)", "nan"),
            ("assemble_ppe with one Inf velocity", "bad",
             ppe + "v = z.copy(); v[3] = np.inf\nresult = sps.assemble_ppe(x, y, z, v, kind, dt=1e-3, l0=L0)", "inf"),
            ("assemble_ppe with one velocity of 1e300", "may",
             ppe + "u = z.copy(); u[3] = 1e300\nresult = sps.assemble_ppe(x, y, u, z, kind, dt=1e-3, l0=L0)", None),
            ("assemble_ppe with 50 particles at one point", "bad",
             "x = np.full(50, 0.05); k = np.zeros(50, np.uint8)\n"
             "result = sps.assemble_ppe(x, x.copy(), 0 * x, 0 * x, k, dt=1e-3, l0=L0)", "one position"),
            ("assemble_ppe with 2 particles 1e-9 l0 apart", "bad",
             ppe + "x = x.copy(); x[1] = x[0] + 2e-11; y = y.copy(); y[1] = y[0]\n"
             "result = sps.assemble_ppe(x, y, z, z, kind, dt=1e-3, l0=L0)", "one position"),
            ("assemble_ppe with arrays of different lengths", "bad",
             ppe + "result = sps.assemble_ppe(x, y[:-1], z, z, kind, dt=1e-3, l0=L0)", None),
            ("assemble_ppe with kind 7", "bad",
             ppe + "k = kind.copy(); k[0] = 7\nresult = sps.assemble_ppe(x, y, z, z, k, dt=1e-3, l0=L0)", None),
            ("assemble_ppe with no particles", "may",
             "e = np.zeros(0)\nresult = sps.assemble_ppe(e, e, e, e, np.zeros(0, np.uint8), dt=1e-3, l0=L0)", None),
            ("assemble_ppe of the tank", "run", "result = sps.assemble_ppe(tank(), dt=1e-3, l0=L0, fy=-9.81)", None),
            ("Particles with NaN positions", "bad",
             "x = np.array([0.0, np.nan]); result = sps.Particles(x, np.zeros(2), np.zeros(2, np.uint8))", "nan"),
            ("Particles with Inf pressure", "bad",
             "z = np.zeros(2)\nresult = sps.Particles(np.arange(2.0), z, z.astype(np.uint8), p=np.array([0, np.inf]))",
             "inf"),
            ("setting p.x with NaN", "bad", "p = tank(); x = p.x; x[0] = np.nan; p.x = x\nresult = p", "nan"),
            ("setting p.u with Inf", "bad", "p = tank(); u = p.u; u[5] = -np.inf; p.u = u\nresult = p", "inf"),
            ("setting p.x of the wrong length", "bad", "p = tank(); p.x = np.zeros(3)\nresult = p", None),
            ("setting p.kind to 9", "bad", "p = tank(); k = p.kind; k[0] = 9; p.kind = k\nresult = p", None),
            ("Simulation.run(end_time=nan)", "bad", "s = sim(); result = s.run(end_time=float('nan'))", "nan"),
            ("Simulation.run(end_time=inf)", "bad", "s = sim(); result = s.run(end_time=float('inf'))", "inf"),
            ("Simulation.run(end_time=-1)", "bad", "s = sim(); result = s.run(end_time=-1)", "-1"),
            ("Simulation.run(end_time=0)", "bad", "s = sim(); result = s.run(end_time=0)", None),
            ("Simulation.run(end_time=1e9)", "bad", "s = sim(); result = s.run(end_time=1e9)", None),
            ("Simulation.run(steps=-1)", "bad", "s = sim(); result = s.run(steps=-1)", None),
            ("Simulation.run(steps=0)", "bad", "s = sim(); result = s.run(steps=0)", None),
            ("Simulation.run(steps=2**40)", "bad", "s = sim(); result = s.run(steps=2**40)", None),
            ("Simulation.run(steps=2**70)", "bad", "s = sim(); result = s.run(steps=2**70)", None),
            ("Simulation.run()", "may", "s = sim(); result = s.run()", None),
            ("Simulation.run(steps=3)", "run", "s = sim(); result = (s.run(steps=3), s.particles)", None),
            ("Simulation(p, None)", "bad", "result = simulation(None)", "domain"),
            ("Simulation(p, 'abc')", "bad", "result = simulation('abc')", "domain"),
            ("Simulation(p, (0, 1, 2))", "bad", "result = simulation((0, 1, 2))", "domain"),
            ("Simulation(p, domain of NaN)", "bad",
             "n = float('nan'); result = simulation((n, n, n, n))", None),
            ("Simulation(p, a domain the particles are outside)", "bad",
             "result = simulation((5, 6, 5, 6))", None),
            ("Simulation(p, a domain of 1e14 cells)", "bad",
             "result = simulation((-1e6, 1e6, -1e6, 1e6))", None),
            ("Simulation(p, gama=0.5)", "bad", "result = simulation(DOMAIN, gama=0.5)", "gama"),
            ("Simulation(p, warm_start=2)", "bad", "result = simulation(DOMAIN, warm_start=2)",
             None),
            ("Simulation of particles at one point", "bad",
             "x = np.full(5, 0.05)\n"
             "result = simulation(DOMAIN, sps.Particles(x, x.copy(), np.zeros(5, np.uint8)))", None),
            ("a huge fill_rectangle", "bad", "result = sps.Particles().fill_rectangle((0, 0, 1e4, 1e4), 1e-4)",
             "particles"),
            ("fill_rectangle of l0 1e-300", "bad", "result = sps.Particles().fill_rectangle((0, 0, 1, 1), 1e-300)",
             None),
            ("fill_rectangle of l0 0", "bad", "result = sps.Particles().fill_rectangle((0, 0, 1, 1), 0.0)", None),
            ("fill_rectangle of l0 nan", "bad",
             "result = sps.Particles().fill_rectangle((0, 0, 1, 1), float('nan'))", None),
            ("fill_rectangle with a NaN corner", "bad",
             "result = sps.Particles().fill_rectangle((0, float('nan'), 1, 1), 0.1)", None),
            ("fill_rectangle of the classic column at l0 = 1 (dambreak --dx 1)", "may",
             "result = sps.Particles().fill_rectangle((0, 0, 0.146, 0.292), 1.0)", None),
            ("fill_rectangle of a rectangle upside down", "may",
             "result = sps.Particles().fill_rectangle((1, 1, 0, 0), 0.1)", None),
            ("a huge add_rectangle_walls", "bad",
             "result = sps.Particles().add_rectangle_walls((0, 0, 1e6, 1e6), 1e-3)", "particles"),
            ("add_rectangle_walls(sides='top|nowhere')", "bad",
             "result = sps.Particles().add_rectangle_walls((0, 0, 1, 1), 0.1, sides='top|nowhere')", None),
            ("add_rectangle_walls(wall_layers=-1)", "bad",
             "result = sps.Particles().add_rectangle_walls((0, 0, 1, 1), 0.1, wall_layers=-1)", None),
            ("Ppe.pressures of a NaN solution", "bad",
             "ppe = sps.assemble_ppe(tank(), dt=1e-3, l0=L0, fy=-9.81)\n"
             "result = ppe.pressures(np.full(ppe.matrix.shape[0], np.nan))", "nan"),
            ("Solver('hypre-pcg:tolerance=1e-6')", "bad", "result = sps.Solver('hypre-pcg:tolerance=1e-6')",
             "tolerance"),
            ("Solver('eigen-cg:tol=nan')", "bad", "result = sps.Solver('eigen-cg:tol=nan')", None),
            ("write_vtp to /dev/full", "bad", "result = sps.write_vtp('/dev/full', tank(), time=0.0)", None),
            ("write_vtp to a directory", "bad", f"result = sps.write_vtp({str(t / 'a_dir')!r}, tank(), time=0.0)",
             None),
            ("write_vtp with time=nan", "bad",
             f"result = sps.write_vtp({str(t / 'w.vtp')!r}, tank(), time=float('nan'))", None),
        ]
        for label, expect, body, say in python_cases:
            add("python", expect, label, py(body), say=say)
        return cases

    def thread_cases(self):
        """(label, app, args): runs whose summary's checks must be bitwise the same on 1 and 2 threads."""
        return [("fsi plate", "fsi", ["--end-time", "0.02", "--frames", "0"]),
                ("structure plate", "structure", ["--dx", "0.004", "--end-time", "0.05", "--frames", "0"]),
                ("dambreak classic", "dambreak", ["--end-time", "0.02", "--frames", "0"])]

    def thread_case(self, name, args):
        checks = []
        for threads in (1, 2):
            what = self.app(name, *args, base=False, threads=threads)
            code, out, err, _ = self.run(what)
            outcome, reason = classify_app({"expect": "run"}, code, out, err, what["out"])
            if outcome != "ran":
                return outcome, f"OMP_NUM_THREADS={threads}: {reason}", err
            checks.append(json.loads((Path(what["out"]) / "summary.json").read_text()).get("checks"))
        if checks[0] != checks[1]:
            differ = sorted(k for k in set(checks[0]) | set(checks[1]) if checks[0].get(k) != checks[1].get(k))
            return "garbage", f"checks differ between 1 and 2 threads: {differ}", ""
        return "ran", f"{len(checks[0])} checks bitwise equal", ""


def main():
    global VERBOSE
    VERBOSE = "--verbose" in sys.argv[1:]
    args = [a for a in sys.argv[1:] if a != "--verbose"]
    if len(args) != 1:
        sys.exit(__doc__)
    start = time.monotonic()
    counts, failures = {}, 0
    with tempfile.TemporaryDirectory(prefix="hostile_sweep.") as tmp:
        sweep = Sweep(args[0], tmp)
        sweep.prepare()
        cases = sweep.cases()
        total = len(cases) + len(sweep.thread_cases())
        print(f"{total} cases in {tmp}, {TIMEOUT} s each at most", flush=True)

        def record(surface, label, outcome, reason, err):
            nonlocal failures
            row = counts.setdefault(surface, {})
            row[outcome] = row.get(outcome, 0) + 1
            if VERBOSE and outcome in CLEAN:
                print(f"({outcome}) {surface}: {label}: {reason}" + (f" | {gist(err)}" if err.strip() else ""))
            if outcome not in CLEAN:
                failures += 1
                print(f"[{outcome}] {surface}: {label}: {reason}")
                if err.strip():
                    print("    " + tail(err).replace("\n", "\n    "))
                sys.stdout.flush()

        for surface, expect, label, what, options in cases:
            case = dict(options, expect=expect, mpi=what.get("mpi"))
            code, out, err, _ = sweep.run(what)
            if "python" in what:
                outcome, reason = classify_python(case, code, out, err)
            else:
                outcome, reason = classify_app(case, code, out, err, what.get("out"))
            record(surface, label, outcome, reason, err if "python" not in what or outcome == "crash" else "")
        for label, name, args in sweep.thread_cases():
            outcome, reason, err = sweep.thread_case(name, args)
            record("threads", f"{label}: 1 vs 2 threads", outcome, reason, err)
        if not Path("/dev/full").is_char_device():
            print("/dev/full is no longer a character device")
            failures += 1

    columns = OUTCOMES + [o for o in EXTRA_OUTCOMES if any(o in row for row in counts.values())]
    width = max(len(s) for s in [*counts, "surface", "total"])
    print()
    print(f"{'surface':{width}}  " + "  ".join(f"{c:>{max(len(c), 4)}}" for c in columns) + "  total")
    for surface in [*sorted(counts), "total"]:
        row = counts.get(surface) or {c: sum(r.get(c, 0) for r in counts.values()) for c in columns}
        print(f"{surface:{width}}  " + "  ".join(f"{row.get(c, 0):>{max(len(c), 4)}}" for c in columns) +
              f"  {sum(row.values()):>5}")
    print(f"\n{failures} of {total} cases not clean; {time.monotonic() - start:.0f} s")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
