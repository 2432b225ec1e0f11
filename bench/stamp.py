"""Where and when a benchmark ran, for chart titles and result tables: the CPU and its cores, the git commit."""
import datetime
import os
import subprocess


def cpu():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


def machine(threads=False):
    """CPU and core count; with threads, also the OMP_NUM_THREADS the runs were given."""
    line = f"{cpu()}, {os.cpu_count()} cores"
    return line + (f", OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}" if threads else "")


def commit():
    """Short hash of HEAD, with -dirty when tracked files differ from it."""
    try:
        c = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                               text=True).stdout.strip()
        return (c or "unknown") + ("-dirty" if dirty else "")
    except OSError:
        return "unknown"


def sweep(what):
    """The stamp of a sweep of app runs (machine with its threads, UTC time, commit), printed; warns first when the
    runs are not on one thread, as the published results were."""
    if os.environ.get("OMP_NUM_THREADS") != "1":
        print(f"note: OMP_NUM_THREADS is not 1; the published {what} were taken with one thread", flush=True)
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    line = f"{machine(threads=True)}; {date}; commit {commit()}"
    print(line, flush=True)
    return line
