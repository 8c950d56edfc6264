#!/usr/bin/env bash
# Installs the dependencies, builds, and runs the main job on the bundled defaults
# (see `odyssey demo --help`); results go to ./demo-out.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
./build/cli/odyssey demo --out demo-out
