"""The PEP 517 build backend of `pip install .` (docs/python.md#pip): the standard library alone, so that pip's isolated
build needs nothing from an index and installs offline. It builds the module with CMake (the Debian packages
scripts/install-deps.sh installs) against a static libsparsemps, so the wheel holds the module and the PETSc solver
module beside it, and nothing else of the build.

Settings (pip install -C key=value): build-dir, the CMake build folder (default build/pip in the source tree, kept so
that a second install builds only what changed); jobs, the build's parallel jobs (default: the processors);
build-type, CMake's (default Release; Debug builds in half the time, unoptimised, with debugging symbols).
"""
import base64
import hashlib
import io
import os
import re
import subprocess
import sys
import sysconfig
import tarfile
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
NAME = "sparsemps"


def _project():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    cmake_version = re.search(r"project\(SparseMPS VERSION ([0-9.]+)", (ROOT / "CMakeLists.txt").read_text())
    if cmake_version is None or cmake_version.group(1) != project["version"]:
        raise RuntimeError("pyproject.toml's version must be CMakeLists.txt's project() version")
    return project


def _metadata(project):
    lines = ["Metadata-Version: 2.1", f"Name: {project['name']}", f"Version: {project['version']}",
             f"Summary: {project['description']}", f"Requires-Python: {project['requires-python']}",
             f"License: {project['license']['text']}"]
    lines += [f"Requires-Dist: {d}" for d in project.get("dependencies", [])]
    return "\n".join(lines) + "\n\n" + (ROOT / "docs" / "python.md").read_text()


def _tags():
    """The wheel's tags for the interpreter that runs the build (the module's ABI is that interpreter's)."""
    python = f"cp{sys.version_info.major}{sys.version_info.minor}"
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return python, python, platform


def _dist_info(project):
    return f"{NAME}-{project['version']}.dist-info"


def _write_metadata(folder, project):
    info = Path(folder) / _dist_info(project)
    info.mkdir(parents=True, exist_ok=True)
    (info / "METADATA").write_text(_metadata(project))
    return info.name


def get_requires_for_build_wheel(config_settings=None):
    return []


def get_requires_for_build_sdist(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    return _write_metadata(metadata_directory, _project())


def _run(command, what):
    print("+", " ".join(str(c) for c in command), flush=True)
    if subprocess.run(command, stdout=sys.stderr).returncode != 0:
        raise RuntimeError(f"{what} failed (above). The build needs the Debian packages of scripts/install-deps.sh: "
                           "run `sudo bash scripts/install-deps.sh` in the source tree first")


def _build(settings):
    build = Path(settings.get("build-dir") or ROOT / "build" / "pip").resolve()
    jobs = str(settings.get("jobs") or os.cpu_count() or 1)
    build_type = settings.get("build-type") or "Release"
    if build_type not in ("Release", "Debug", "RelWithDebInfo", "MinSizeRel"):
        raise RuntimeError(f"build-type {build_type!r} is none of Release, Debug, RelWithDebInfo, MinSizeRel")
    _run(["cmake", "-S", ROOT, "-B", build, f"-DCMAKE_BUILD_TYPE={build_type}", "-DBUILD_SHARED_LIBS=OFF",
          "-DSPARSEMPS_BUILD_TESTS=OFF", "-DSPARSEMPS_BUILD_APPS=OFF", "-DSPARSEMPS_BUILD_BENCH=OFF",
          "-DSPARSEMPS_BUILD_PYTHON=ON", f"-DPython3_EXECUTABLE={sys.executable}"], "configuring with CMake")
    _run(["cmake", "--build", build, "--target", "sparsemps_python", "sparsemps_petsc", "-j", jobs],
         "building the module")
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    module = build / "python" / f"{NAME}{suffix}"
    petsc = build / "lib" / "libsparsemps_petsc.so"
    for path in (module, petsc):
        if not path.is_file():
            raise RuntimeError(f"the build made no {path} (were pybind11-dev and python3-dev found? "
                               "CMake's output above says)")
    # The library finds the PETSc module beside the file that holds it: here the module (mps/solvers/petsc.cpp).
    return {module.name: module.read_bytes(), petsc.name: petsc.read_bytes()}


def _record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    project = _project()
    files = _build(config_settings or {})
    python, abi, platform = _tags()
    info = _dist_info(project)
    files[f"{info}/METADATA"] = _metadata(project).encode()
    files[f"{info}/WHEEL"] = (f"Wheel-Version: 1.0\nGenerator: {NAME}_build\nRoot-Is-Purelib: false\n"
                              f"Tag: {python}-{abi}-{platform}\n").encode()
    record = [_record_line(name, data) for name, data in files.items()] + [f"{info}/RECORD,,"]
    files[f"{info}/RECORD"] = ("\n".join(record) + "\n").encode()
    wheel = f"{NAME}-{project['version']}-{python}-{abi}-{platform}.whl"
    with zipfile.ZipFile(Path(wheel_directory) / wheel, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in files.items():
            entry = zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))  # the same bytes from the same build
            entry.external_attr = (0o755 if name.endswith(".so") else 0o644) << 16
            entry.compress_type = zipfile.ZIP_DEFLATED
            archive.writestr(entry, data)
    return wheel


def build_sdist(sdist_directory, config_settings=None):
    """The source tree's committed files (git ls-files), as PEP 517 asks of every backend."""
    project = _project()
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True)
    if listed.returncode != 0:
        raise RuntimeError("an sdist is made from a git checkout (git ls-files lists its files)")
    base = f"{NAME}-{project['version']}"
    name = f"{base}.tar.gz"
    with tarfile.open(Path(sdist_directory) / name, "w:gz", format=tarfile.PAX_FORMAT) as archive:
        for path in sorted(p for p in listed.stdout.decode().split("\0") if p):
            archive.add(ROOT / path, arcname=f"{base}/{path}", recursive=False)
        pkg_info = _metadata(project).encode()
        entry = tarfile.TarInfo(f"{base}/PKG-INFO")
        entry.size = len(pkg_info)
        archive.addfile(entry, io.BytesIO(pkg_info))
    return name
