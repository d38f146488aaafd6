#!/usr/bin/env bash
# Installs Open3D, trimesh and embreex from PyPI beside raybatch in a virtual environment
# (target/python-bench-venv) and runs compare.py: bash python/benchmarks/compare.sh [compare.py
# arguments]. Open3D's wheel needs libusb-1.0 (Debian: apt-get install libusb-1.0-0).
set -euo pipefail
cd "$(dirname "$0")/../.."

venv=target/python-bench-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet maturin numpy open3d-cpu trimesh embreex
(cd python && VIRTUAL_ENV="$PWD/../$venv" PATH="$PWD/../$venv/bin:$PATH" maturin develop --release --quiet)
"$venv/bin/python" python/benchmarks/compare.py "$@"
