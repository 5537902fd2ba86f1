#!/usr/bin/env bash
# The Python package (std-ext/python): build its abi3 wheel with maturin,
# install it into a fresh virtual environment, identify the paper rotor
# from a simulated sweep with `python -c`, install ROSS 3.1, and run its
# pytest suite, which compares every result with the `rotorid` command
# line's JSON and hands an identified rotor to ROSS and back.
#
#   .ci/python.sh        (after `cargo test`, whose rotorid binary it uses)
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

banner() {
  echo "!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!"
  for line in "$@"; do echo "!! $line"; done
  echo "!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!"
}

# ROSS 3.1 needs Python 3.13: where pyenv has it, it is the one used.
if PYENV_VERSION=3.13.0 python3.13 -c 'import sys' >/dev/null 2>&1; then
  export PYENV_VERSION=3.13.0
fi
PY=""
for p in python3.13 python3.12 python3.11 python3.10 python3; do
  if command -v "$p" >/dev/null 2>&1 && "$p" -c 'import sys, venv; sys.exit(sys.version_info < (3, 10))' 2>/dev/null; then
    PY=$p
    break
  fi
done
if [ -z "$PY" ]; then
  banner "WARNING: no Python 3.10 or later: the Python package was NOT built or tested"
  exit 0
fi
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
echo "-- $($PY --version) venv in $OUT/venv"
"$PY" -m venv "$OUT/venv"
if ! "$OUT/venv/bin/pip" install -q maturin pytest numpy; then
  banner "WARNING: could not install maturin, pytest and numpy from the package index:" \
         "the Python package was NOT built or tested"
  exit 0
fi

# An optimised build without debug information (`[profile.python]`).
echo "-- maturin build (abi3 wheel, profile python)"
"$OUT/venv/bin/maturin" build -q --profile python -m std-ext/python/Cargo.toml -o "$OUT/wheels"
"$OUT/venv/bin/pip" install -q "$OUT"/wheels/rotorid-*.whl

echo "-- python -c: identify the paper rotor from a simulated sweep"
(cd "$OUT" && "$OUT/venv/bin/python" -c '
import numpy as np, rotorid
m = rotorid.Model.paper()
speeds = np.arange(50.0, 15001.0, 50.0)
q = m.simulate(speeds, noise=0.005, noise_floor=0.5e-6, balance_grade=6.3)
ident = rotorid.identify(m, speeds, q)
print("k (N/m):", ident.k.round(-3).tolist())
print("unbalance m e (kg m):", np.abs(ident.unbalance).round(7).tolist())
')

echo "-- pytest (against the rotorid command line)"
# The binary the test command built for the integration tests.
ROTORID_BIN="${CARGO_TARGET_DIR:-$ROOT/target}/debug/rotorid"
if [ ! -x "$ROTORID_BIN" ]; then
  echo "error: $ROTORID_BIN missing: run the test command first" >&2
  exit 1
fi
export ROTORID_BIN

# ROSS 3.1 (and the exact versions of its dependencies the fixtures were
# made with), so that the ROSS round trip runs rather than skips; about
# 2-3 minutes from the package index. Without it the test is skipped with
# its reason printed.
echo "-- ROSS 3.1 for the round-trip test"
if ! timeout 600 "$OUT/venv/bin/pip" install -q -r tests/data/ross/requirements.txt; then
  banner "WARNING: could not install ROSS 3.1 from the package index:" \
         "the ROSS round trip is skipped"
fi
(cd "$OUT" && "$OUT/venv/bin/python" -m pytest -q -rs -p no:cacheprovider "$ROOT/std-ext/python/tests")
