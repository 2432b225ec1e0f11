#!/usr/bin/python3
"""`pip install .` as a Python user does it (docs/python.md#pip), offline: into a fresh virtual environment of
Debian's Python (with its NumPy and SciPy), with --no-index so that nothing may come from an index, built unoptimised
(-C build-type=Debug) to take half the time. The installed module must import from outside the source tree, with no
PYTHONPATH, solve with the library's backends and PETSc's (its module shipped beside the extension), and uninstall
cleanly. The wheel holds the module, the PETSc module and
its metadata alone, and names the interpreter's tags.

  tests/pip_install.py BUILD_DIR   (the wheel's CMake build goes to BUILD_DIR/pip-wheel)
"""
import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

SOURCE = Path(__file__).resolve().parent.parent
CHECK = r"""
import sys, numpy as np, scipy.sparse as sp, sparsemps
assert "site-packages" in sparsemps.__file__ and sys.argv[1] in sparsemps.__file__, sparsemps.__file__
n = 200
A = sp.diags([-np.ones(n - 1), 2.0 * np.ones(n) + 1e-3, -np.ones(n - 1)], [-1, 0, 1], format="csr")
b = np.ones(n)
for spec in ("cholmod", "hypre-pcg", "petsc:ksp_type=cg,pc_type=gamg"):
    x, report = sparsemps.solve(A, b, spec)
    residual = np.linalg.norm(b - A @ x) / np.linalg.norm(b)
    assert residual < 1e-6, (spec, residual)
    print(spec, report.backend, report.iterations, f"{residual:.1e}")
print("version", sparsemps.__version__)
"""


def settings(build):
    # The wheel's build folder, under the test's build; unoptimised: the packaging is under test, not the speed.
    return ["--config-settings", f"build-dir={build / 'pip-wheel'}", "--config-settings", "build-type=Debug"]


def run(command, **kwargs):
    proc = subprocess.run([str(c) for c in command], capture_output=True, text=True, **kwargs)
    return proc.returncode, proc.stdout + proc.stderr


def main():
    build = Path(sys.argv[1]).resolve()
    failures = []
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PIP_", "PYTHON"))}
    env.update(PIP_NO_INPUT="1", PIP_DISABLE_PIP_VERSION_CHECK="1", OMP_NUM_THREADS="1")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        venv = tmp / "venv"
        code, out = run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", venv], env=env)
        if code != 0:
            print(out)
            return 1
        python = venv / "bin" / "python"
        wheels = tmp / "wheels"
        code, out = run([python, "-m", "pip", "wheel", "--no-index", "--no-deps", "--no-cache-dir", "-w", wheels,
                         *settings(build), SOURCE], env=env, cwd=tmp)
        if code != 0:
            print(out[-4000:])
            return 1
        [wheel] = list(wheels.glob("*.whl"))
        tag = f"cp{sys.version_info.major}{sys.version_info.minor}"
        if not wheel.name.startswith(f"sparsemps-") or f"-{tag}-{tag}-linux_" not in wheel.name:
            failures.append(f"the wheel's name {wheel.name} does not carry this interpreter's tags {tag}")
        names = sorted(zipfile.ZipFile(wheel).namelist())
        unexpected = [n for n in names if not (n.startswith("sparsemps.cpython-") or n == "libsparsemps_petsc.so"
                                               or n.startswith("sparsemps-") and ".dist-info/" in n)]
        if unexpected or len(names) != 5:
            failures.append(f"the wheel holds {names}")
        code, out = run([python, "-m", "pip", "install", "--no-index", "--no-cache-dir", *settings(build), SOURCE],
                        env=env, cwd=tmp)
        if code != 0:
            print(out[-4000:])
            return 1
        code, out = run([python, "-c", CHECK, str(venv)], env=env, cwd=tmp)
        print(out.strip())
        if code != 0:
            failures.append("the installed module failed its check (above)")
        code, out = run([python, "-m", "pip", "uninstall", "-y", "sparsemps"], env=env, cwd=tmp)
        left = [p.name for p in (venv / "lib").rglob("*sparsemps*")]
        if code != 0 or left:
            failures.append(f"uninstall exited {code} and left {left}")
    for f in failures:
        print("FAIL:", f)
    print("pip install .: offline build, install, import, solve and uninstall" + (" failed" if failures else " passed"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
