#!/usr/bin/env bash
# Installs the Debian 12 packages odyssey builds and tests with. Runs as root, or through sudo.
set -euo pipefail
packages=(
  build-essential cmake
  libeigen3-dev libceres-dev libglm-dev libtinygltf-dev libopenmesh-dev nlohmann-json3-dev
  libgtest-dev libbenchmark-dev zlib1g-dev libpng-dev libjpeg-dev
  libbullet-dev pkg-config  # props that react: rigid-body physics (physics/, the double-precision build, found through pkg-config)
  python3-numpy python3-pil  # tests read the npz files with numpy and the images with PIL, as the trackers' loaders do
  python3-dev pybind11-dev python3-pytest  # the Python module (python/) and its tests (tests/python_module/)
  blender  # tests import the scene GLB into Blender 3.4 headless (80 MB download, 520 MB installed)
  slurmctld slurmd slurm-client munge  # the batch's cluster path runs on a one-node Slurm (scripts/slurm-local.sh)
)
as_root=()
[ "$(id -u)" -eq 0 ] || as_root=(sudo)
"${as_root[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
# The Khronos glTF validator checks every GLB the tests write. Node and npm come with the
# machine image; without them the validator tests skip and say so.
if command -v npm >/dev/null 2>&1; then
  npm install --silent --prefix "$(dirname "$0")/../tools/gltf-validator" --package-lock=false >/dev/null
fi
