#!/usr/bin/env bash
# Installs the Debian 12 packages odyssey builds and tests with. Runs as root, or through sudo.
set -euo pipefail
packages=(
  build-essential cmake
  libeigen3-dev libceres-dev libglm-dev libtinygltf-dev libopenmesh-dev nlohmann-json3-dev
  libgtest-dev libbenchmark-dev zlib1g-dev
  python3-numpy  # tests cross-check the npz files with numpy
)
as_root=()
[ "$(id -u)" -eq 0 ] || as_root=(sudo)
"${as_root[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
