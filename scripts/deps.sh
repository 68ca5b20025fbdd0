#!/usr/bin/env bash
# Installs the Debian 12 packages GrainTwin needs, and only those that are missing (checked with
# dpkg). Nothing is downloaded from anywhere but Debian's archive. Root or sudo required to install.
# Extra package names as arguments are installed too (scripts/fuzz.sh adds clang and libFuzzer).
set -euo pipefail

PACKAGES=(
  # toolchain
  g++ cmake ninja-build make pkg-config git
  # libraries (docs/dependencies.md says why each is there)
  libhdf5-dev libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev libeigen3-dev libgsl-dev
  libtiff-dev libpng-dev libgtest-dev
  # fdemrun scene files (TOML with arrays of tables)
  libtomlplusplus-dev
  # fdemrun across ranks and machines (mpi/ library; its tests run through mpirun)
  libopenmpi-dev openmpi-bin
  # tetrahedral meshing of grains (shapes2mesh, fdemrun): only the mesh/ library links it
  libgmsh-dev
  # surface remeshing of grains before gmsh fills them (mesh/surface_remesh.cpp only)
  libcgal-dev
  # Python from Debian for the h5py interoperability checks, reference baselines and plots;
  # VTK's own reader checks that ParaView opens what we write
  python3 python3-numpy python3-h5py python3-matplotlib python3-vtk9
  # the X server VTK renders the report's 3D pictures on, without a screen
  xvfb
  # a headless browser that renders the report page in its test (every chart must decode)
  chromium
)
PACKAGES+=("$@")

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "deps: all ${#PACKAGES[@]} Debian packages present"
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "deps: missing ${missing[*]}; run as root or install sudo" >&2; exit 1; }
  SUDO=sudo
fi
echo "deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
