#!/usr/bin/env bash
# Install the Python oracles for the part-mesh collision test (crates/post/tests/
# collide_oracle.rs) and the slicing test (crates/plan/tests/slice_oracle.rs): a
# project-local virtual environment in .tools/py with pinned trimesh, numpy, scipy
# (trimesh's proximity queries use its k-d tree), rtree (trimesh's triangle index for
# ray and proximity queries), networkx and shapely (trimesh's sections as closed paths).
# No system install. Safe to run again; prints the interpreter's path.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
dest="$here/.tools/py"
py="$dest/bin/python"
pins=(numpy==2.4.6 scipy==1.17.1 trimesh==5.2.0 rtree==1.4.1 networkx==3.6.1 shapely==2.2.0)
. "$here/scripts/lib/venv.sh"
pinned_venv "$dest" "numpy scipy trimesh rtree networkx shapely" "${pins[@]}"
"$py" -c "import trimesh, numpy, scipy, rtree; print('python oracle ready:', '$py', 'trimesh', trimesh.__version__, 'numpy', numpy.__version__, 'scipy', scipy.__version__, 'rtree', rtree.__version__)"
