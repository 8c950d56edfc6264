#!/usr/bin/env bash
# Installs the dependencies, builds, and runs the whole test suite under ctest: once in a random
# order, then the end-to-end tests of the odyssey command (every *Cli* suite) three more times,
# so a test that depends on another's files or on timing fails here rather than now and then.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j "$(nproc)" --schedule-random
ctest --test-dir build --output-on-failure -j "$(nproc)" --schedule-random -R 'Cli' --repeat until-fail:3
