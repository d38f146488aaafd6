#!/usr/bin/env bash
# Builds the Python package into a virtual environment made from PyPI (target/python-venv) and
# runs its tests: bash python/test.sh [pytest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."

venv=target/python-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet maturin numpy pytest "dask[array,distributed]" pillow
# The tests compare answers with the `raybatch query` command.
cargo build --release -p raybatch-tools --bin raybatch
(cd python && VIRTUAL_ENV="$PWD/../$venv" PATH="$PWD/../$venv/bin:$PATH" maturin develop --release --quiet)
cd python && "../$venv/bin/python" -m pytest -q tests "$@"
