#!/usr/bin/env bash
# The project's test command (README, .ci/run): installs LinuxCNC's rs274 for the
# comparison tests, a Python venv with trimesh for the collision and slicing oracles and
# the real meshes of the slicing oracle (scripts/install-meshes.sh), one with the Robotics
# Toolbox for the robot oracle (.tools/py-rtb), one with Open3D for the distance oracle
# (.tools/py-o3d), then runs
# every test of the workspace. rs274 is required here, so
# the comparison can never be skipped silently.
set -euo pipefail
# Nothing here reads standard input: close it, so no tool ever reads stray bytes
# from whatever stdin the runner left open.
exec </dev/null
cd "$(dirname "$0")/.."
./scripts/install-rs274.sh
./scripts/install-python.sh
./scripts/install-meshes.sh
./scripts/install-robotics.sh
./scripts/install-open3d.sh
LAMPOST_REQUIRE_RS274=1 LAMPOST_REQUIRE_PY=1 cargo test --workspace --locked
