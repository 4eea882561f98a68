#!/usr/bin/env bash
# Installs the Debian packages dgmesh builds, tests and demos with. Idempotent: does nothing when
# everything is there. Run as root (or with sudo available).
#   bash scripts/deps.sh          this machine (bookworm): everything, the lanes' tools included
#   bash scripts/deps.sh --lane   inside a test lane's root (scripts/lanes.sh): build and test only
set -euo pipefail
PKGS=(
  cmake g++ make pkg-config
  libeigen3-dev libnanoflann-dev libosd-dev libqhull-dev libsuitesparse-dev
  pybind11-dev python3-dev python3-numpy python3-pytest python3-hypothesis libgtest-dev
  blender          # runs the add-on tests and the demo (3.4 here, 4.3 in trixie, 5.x in sid)
  libcgal-demo     # ships data.tar.gz with the scanned test meshes (unpacked at run time)
  libopenblas0-pthread  # optimised BLAS for UMFPACK's dense fronts (the default is the reference BLAS)
  xvfb xauth       # a real window for the interactive (modal, Esc) operator test; xvfb-run needs xauth
  libegl1 libgl1-mesa-dri  # Blender 4.x renders through EGL even in the background
)
if [ "${1:-}" != --lane ]; then
  PKGS+=(
    libcgal-dev    # bench only: CGAL peers in fair_restore and unwrap_quality (bench/tools/*.cpp)
    debootstrap    # makes the test lanes' Debian roots (scripts/lanes.sh)
    python3-pyflakes clang-format  # the style checks of scripts/test.sh (this machine only)
  )
fi
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
