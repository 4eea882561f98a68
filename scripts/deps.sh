#!/usr/bin/env bash
# Installs the Debian packages dgmesh builds, tests and demos with. Idempotent: does nothing when
# everything is there. Run as root (or with sudo available).
set -euo pipefail
PKGS=(
  cmake g++ make pkg-config
  libeigen3-dev libnanoflann-dev libosd-dev libqhull-dev libsuitesparse-dev
  pybind11-dev python3-dev python3-numpy python3-pytest libgtest-dev
  blender          # 3.4.1, runs the add-on tests and the demo
  libcgal-demo     # ships data.tar.gz with the scanned test meshes (unpacked at run time)
  libcgal-dev      # bench only: CGAL peers in fair_restore and unwrap_quality (bench/tools/*.cpp)
  xvfb             # a real window for the interactive (modal, Esc) operator test
  libopenblas0-pthread  # optimised BLAS for UMFPACK's dense fronts (the default is the reference BLAS)
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "deps: installing ${missing[*]}"
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
