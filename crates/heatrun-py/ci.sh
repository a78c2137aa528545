#!/usr/bin/env bash
# The Python package's CI: builds the wheel with maturin, installs it into a fresh
# virtual environment and runs the pytest suite (crates/heatrun-py/tests) against the
# shipped fixtures.
#
#   bash crates/heatrun-py/ci.sh
#
# Environment:
#   CARGO_TARGET_DIR  the wheel's own target directory [default: ~/.cache/heatrun-py-target]
#                     (the package is not a default member: the README's build never
#                     compiles it, and its build here does not touch the README's);
#   HEATRUN           the `heatrun` binary, for the tests that compare with the command
#                     line (report JSON, identify's model); they skip without it;
#   PYTHON            the interpreter the environments are made from [default: python3].
# Needs PyPI (maturin, pytest, numpy, pandas, mypy for the stubs' check; dask and distributed for the fleet test,
# which skips where they cannot be installed).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
python="${PYTHON:-python3}"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/heatrun-py-target}"
export CARGO_TERM_COLOR=never
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# The build's tools in an environment of their own (not the one the wheel is tested in).
"$python" -m venv "$work/build"
"$work/build/bin/pip" install --quiet --disable-pip-version-check "maturin>=1.5,<2"
"$work/build/bin/maturin" build --release --locked -m "$here/Cargo.toml" \
    --interpreter "$python" --out "$work/wheels"

# A fresh environment with nothing of the source tree: the wheel and the test tools.
"$python" -m venv "$work/test"
pip=("$work/test/bin/pip" install --quiet --disable-pip-version-check)
"${pip[@]}" "$work"/wheels/heatrun-*.whl pytest numpy pandas mypy
"${pip[@]}" dask distributed || echo "ci.sh: dask/distributed not installed: the fleet test skips"

# The type stubs against the extension module as built: every function, its parameters
# and their defaults.
"$work/test/bin/python" -m mypy.stubtest heatrun._heatrun

# From the repository's root, so `fixtures/…` paths read as in the README. Only the
# tests' own folder joins sys.path (the source tree's python/ does not): the installed
# wheel is what is tested.
cd "$root"
status=0
HEATRUN_ROOT="$root" "$work/test/bin/python" -m pytest -q -p no:cacheprovider \
    "$here/tests" || status=$?
if [ "$status" -eq 5 ]; then
    echo "ci.sh: pytest collected no tests in $here/tests" >&2
    exit 1
fi
exit "$status"
