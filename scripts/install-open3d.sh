#!/usr/bin/env bash
# Install the distance oracle (crates/cli/tests/inspect_oracle.rs and `cargo xtask bench
# inspect`): Open3D's CPU build, whose RaycastingScene.compute_signed_distance checks
# lampost-inspect's signed distances, in its own project-local virtual environment
# .tools/py-o3d (kept apart from .tools/py and .tools/py-rtb so no pins clash). Pinned
# versions; no system install. Safe to run again; prints the interpreter's path.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
dest="$here/.tools/py-o3d"
py="$dest/bin/python"
pins=(open3d-cpu==0.19.0 numpy==1.26.4)
. "$here/scripts/lib/venv.sh"
pinned_venv "$dest" "open3d" "${pins[@]}"
"$py" -c "import open3d, numpy; print('distance oracle ready:', '$py', 'open3d', open3d.__version__, 'numpy', numpy.__version__)"
