#!/usr/bin/env bash
# Installs the Debian 12 packages that only the benchmark references need (the build and the tests
# need none of them; scripts/deps.sh covers those): scikit-image + scipy for
# bench/reference/skimage_segment.py and ITK 5.2 for bench/reference/itk_segment.cpp, both used by
# ct2labels_bench; h5py for the Python benches that read fdemrun's results (fdem_triaxial_bench.py,
# fdem_deformable_damping_bench.py; Debian's, so run them with /usr/bin/python3); LIGGGHTS 3.8 (liggghts) for bench/fdem_crosscheck.py, the independent DEM code
# fdemrun's sphere impacts are checked against. Nothing comes from anywhere but Debian's archive;
# root or sudo to install.
# Afterwards: cmake -S . -B build (it finds ITK) && ninja -C build ct2labels_bench itk_segment
set -euo pipefail
PACKAGES=(python3-skimage python3-scipy python3-h5py libinsighttoolkit5-dev liggghts)
installed=$(dpkg-query -W -f='${Status}\n' "${PACKAGES[@]}" 2>/dev/null | grep -c "install ok installed" || true)
if [ "$installed" -eq "${#PACKAGES[@]}" ]; then
  echo "deps-bench: ${PACKAGES[*]} present"
  exit 0
fi
[ "$(id -u)" -eq 0 ] && SUDO="" || SUDO=sudo
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${PACKAGES[@]}"
