#!/usr/bin/env bash
# Installs the dependencies, builds, and runs the whole test suite under ctest: once in a random
# order, then the end-to-end tests of the odyssey command (every *Cli* suite) three more times,
# so a test that depends on another's files or on timing fails here rather than now and then.
# The batch's Slurm test needs a cluster: as root, this starts a one-node Slurm on this machine
# for the run (scripts/slurm-local.sh) unless one answers already; without one that test skips
# and says why, unless ODYSSEY_REQUIRE_SLURM=1 (CI) makes it fail.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
if ! sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated)' && [ "$(id -u)" -eq 0 ]; then
  if bash scripts/slurm-local.sh start; then
    trap 'bash scripts/slurm-local.sh stop' EXIT
  fi
fi
ctest --test-dir build --output-on-failure -j "$(nproc)" --schedule-random
ctest --test-dir build --output-on-failure -j "$(nproc)" --schedule-random -R 'Cli' --repeat until-fail:3
