#!/usr/bin/env bash
# Installs the Debian packages SparseMPS builds and runs with, skipping what is already installed.
# Everything comes from Debian: no downloads, no vendored third-party code.
set -euo pipefail

packages=(
  cmake make g++ pkg-config
  libeigen3-dev          # sparse matrices, CG/BiCGSTAB, incomplete Cholesky
  libsuitesparse-dev     # CHOLMOD
  libopenblas-dev        # optimised BLAS behind CHOLMOD's supernodal factorisation
  libhypre-dev           # BoomerAMG
  libopenmpi-dev openmpi-bin   # MPI for hypre and the distributed particles; mpirun runs the tests labelled mpi
  libtrilinos-zoltan-dev # Zoltan's RCB partition of particles over MPI ranks (mps/parallel/distributed.hpp)
  libpetsc-real-dev      # PETSc's KSP behind the registry (the petsc solver)
  libgtest-dev
  libcli11-dev nlohmann-json3-dev libtomlplusplus-dev
  zlib1g-dev             # the .vtp frames' compression
  libpng-dev             # the acoustic app's pressure maps
  python3-vtk9           # VTK's own reader in the frame tests and scripts/compare_results.py
  python3-jsonschema     # summary.json against docs/summary.schema.json (ReplayFromConfig, scripts/compare_results.py)
  python3-cbor2          # checkpoints read as documented (RestartApps, docs/restart.md)
  doxygen                # the API reference (make docs) and the test that every public member is documented
  python3-matplotlib python3-numpy   # charts from bench/ and apps/
  pybind11-dev python3-dev python3-scipy python3-pytest   # the Python module sparsemps and its tests (python/)
  python3-pip python3-venv   # pip install . into a virtual environment (PipInstall, docs/python.md#pip)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  sudo=sudo
fi
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
