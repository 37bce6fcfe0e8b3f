#!/usr/bin/env bash
# Install the robot oracle (crates/robot/tests/rtb_oracle.rs): the Robotics Toolbox for
# Python (Corke), whose models.DH.Puma560 checks lampost-robot's forward and inverse
# kinematics, in its own project-local virtual environment .tools/py-rtb (kept apart from
# .tools/py so neither's pins can break the other). Pinned versions; no system install.
# Safe to run again; prints the interpreter's path.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
dest="$here/.tools/py-rtb"
py="$dest/bin/python"
pins=(roboticstoolbox-python==1.5.0 spatialmath-python==1.1.18 rtb-data==2.0.0 numpy==2.4.6 scipy==1.17.1 matplotlib==3.11.2 ansitable==1.2.0)
. "$here/scripts/lib/venv.sh"
pinned_venv "$dest" "roboticstoolbox" "${pins[@]}"
"$py" -c "import roboticstoolbox as rtb, numpy; print('robot oracle ready:', '$py', 'roboticstoolbox', rtb.__version__, 'numpy', numpy.__version__)"
