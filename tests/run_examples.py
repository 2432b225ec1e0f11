#!/usr/bin/python3
"""Runs the examples of examples/ as a user would, each checking its own results (examples/README.md):

  tests/run_examples.py BUILD_DIR cpp|python|notebook

cpp: examples/cpp/tank_probes, built with the project. python: examples/python/dambreak.py with the build's module.
notebook: every code cell of examples/notebooks/*.ipynb executed in order in one namespace, as Jupyter's kernel would
(the notebooks are plain Python: a cell with an IPython magic or shell escape is refused), with a shortened run.
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

SOURCE = Path(__file__).resolve().parent.parent


def run_notebook(path, out):
    notebook = json.loads(path.read_text())
    namespace = {"__name__": "__main__"}
    for k, cell in enumerate(c for c in notebook["cells"] if c["cell_type"] == "code"):
        source = "".join(cell["source"])
        if any(line.lstrip().startswith(("%", "!")) for line in source.splitlines()):
            raise SystemExit(f"{path.name}, code cell {k}: an IPython magic or shell escape; keep notebooks plain Python")
        exec(compile(source, f"{path.name}[cell {k}]", "exec"), namespace)
    produced = sorted(p.name for p in Path(out).iterdir())
    print(f"{path.name}: {k + 1} code cells ran; wrote {produced}")
    return bool(produced)


def main():
    build, which = Path(sys.argv[1]).resolve(), sys.argv[2]
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(build / "python"), MPLBACKEND="Agg")
    with tempfile.TemporaryDirectory() as tmp:
        if which == "cpp":
            return subprocess.run([build / "examples" / "cpp" / "tank_probes", "0.3", Path(tmp) / "probes.csv"],
                                  env=env).returncode
        if which == "python":
            return subprocess.run(["/usr/bin/python3", SOURCE / "examples" / "python" / "dambreak.py", "0.3", tmp],
                                  env=env).returncode
        if which == "notebook":
            os.environ.update(SPARSEMPS_EXAMPLE_END_TIME="0.1", SPARSEMPS_EXAMPLE_OUT=tmp, MPLBACKEND="Agg",
                              OMP_NUM_THREADS="1")
            sys.path.insert(0, str(build / "python"))
            ok = all(run_notebook(p, tmp) for p in sorted((SOURCE / "examples" / "notebooks").glob("*.ipynb")))
            return 0 if ok else 1
    raise SystemExit(f"unknown example kind {which!r}: cpp, python or notebook")


if __name__ == "__main__":
    sys.exit(main())
