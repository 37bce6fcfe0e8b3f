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
# The oracles install (downloads, mostly) while the tests compile.
install_log=$(mktemp)
(
    ./scripts/install-rs274.sh
    ./scripts/install-python.sh
    ./scripts/install-meshes.sh
    ./scripts/install-robotics.sh
    ./scripts/install-open3d.sh
) >"$install_log" 2>&1 &
install_pid=$!
trap 'kill "$install_pid" 2>/dev/null || true; rm -f "$install_log"' EXIT
have_nextest=false
if cargo nextest --version >/dev/null 2>&1; then
    have_nextest=true
    cargo nextest run --workspace --locked --no-run
else
    cargo test --workspace --locked --no-run
fi
install_status=0
wait "$install_pid" || install_status=$?
cat "$install_log"
if [ "$install_status" -ne 0 ]; then
    echo "test.sh: installing the test oracles failed (exit $install_status); see above" >&2
    exit 1
fi
export LAMPOST_REQUIRE_RS274=1 LAMPOST_REQUIRE_PY=1
# cargo-nextest, where installed, runs the test binaries side by side (cargo test runs
# them one after another, so one long test holds a core idle); it does not run doc
# tests, so they run after it. Without nextest: cargo test, which runs both.
if $have_nextest; then
    cargo nextest run --workspace --locked --no-fail-fast
    cargo test --workspace --locked --doc
else
    cargo test --workspace --locked
fi
