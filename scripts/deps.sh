#!/usr/bin/env bash
# Installs the Debian 12 packages mpskit's examples and tests need, only when one is missing
# (so a machine that has them runs no apt at all). Needs root on a fresh machine.
set -euo pipefail
pkgs=(g++ cmake make libeigen3-dev libnanoflann-dev doctest-dev libsuitesparse-dev gnuplot-nox python3-meshio)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "mpskit: installing Debian packages: ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
