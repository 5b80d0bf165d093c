#!/usr/bin/env bash
# Installs the Debian packages tet2spline needs to build and test. Idempotent:
# asks apt only for what is missing, and does nothing when all is installed.
set -euo pipefail
packages=(
  g++ make cmake ccache pkg-config ca-certificates
  libeigen3-dev libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libtet1.5-dev libceres-dev libsuitesparse-dev libtbb-dev
  libocct-foundation-dev libocct-modeling-data-dev libocct-modeling-algorithms-dev libocct-data-exchange-dev
  libgtest-dev libcli11-dev nlohmann-json3-dev zlib1g-dev
  gmsh tetgen
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then exit 0; fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO=sudo; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
