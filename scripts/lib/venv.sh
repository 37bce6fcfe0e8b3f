# Sourced by the install-*.sh scripts that set up a Python oracle: the one way a
# project-local virtual environment with pinned packages is made.
#
#   pinned_venv DEST "IMPORTS" PIN...
#
# makes DEST a virtual environment (again if it is not one), and installs the PINs
# (name==version) unless every one is there at its version and `import IMPORTS` works.
# No system install; safe to run again.
pinned_venv() {
  local dest=$1 imports=$2
  shift 2
  local py="$dest/bin/python"
  if [ ! -x "$py" ]; then
    rm -rf "$dest"
    python3 -m venv "$dest"
  fi
  if ! "$py" - "$imports" "$@" <<'PY' >/dev/null 2>&1
import importlib
import sys
from importlib.metadata import version
for pin in sys.argv[2:]:
    name, want = pin.split("==")
    assert version(name) == want, pin
for module in sys.argv[1].split():
    importlib.import_module(module)
PY
  then
    "$py" -m pip install --quiet --disable-pip-version-check "$@"
  fi
}
