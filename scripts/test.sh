#!/usr/bin/env bash
# The project's test command (README, .ci/run): installs LinuxCNC's rs274 for the
# comparison tests, then runs every test of the workspace. rs274 is required here, so
# the comparison can never be skipped silently.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-rs274.sh
LAMPOST_REQUIRE_RS274=1 cargo test --workspace --locked
