#!/usr/bin/env bash
# Create the virtual environment and install airmat with its test extras.
# Installs the system libraries open3d needs (libgl1, libegl1, libusb-1.0-0, libgomp1) and chromium
# (the report's browser test) when missing.
set -euo pipefail
VENV=${1:-.venv}

need=()
for pair in libgl1:libGL.so.1 libegl1:libEGL.so.1 libusb-1.0-0:libusb-1.0.so.0 libgomp1:libgomp.so.1; do
    pkg=${pair%%:*}; lib=${pair#*:}
    if ! ldconfig -p 2>/dev/null | grep -q "$lib"; then need+=("$pkg"); fi
done
if [ ${#need[@]} -gt 0 ]; then
    echo "bootstrap: installing system libraries for open3d: ${need[*]}"
    if [ "$(id -u)" -eq 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO="sudo"; else
        echo "bootstrap: need root to install ${need[*]} (apt-get install ${need[*]})" >&2; exit 2; fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need[@]}" >/dev/null
fi

# headless Chromium opens report.html in tests/report (a real browser, offline)
if ! command -v chromium >/dev/null; then
    echo "bootstrap: installing chromium for the report's browser test"
    if [ "$(id -u)" -eq 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO="sudo"; else
        echo "bootstrap: need root to install chromium (apt-get install chromium)" >&2; exit 2; fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium >/dev/null
fi

PYTHON=""
for cand in python3.11 python3.12 python3.10 python3; do
    if command -v "$cand" >/dev/null && "$cand" -c 'import sys; sys.exit(sys.version_info < (3, 10))'; then
        PYTHON=$cand; break
    fi
done
[ -n "$PYTHON" ] || { echo "bootstrap: Python >= 3.10 not found" >&2; exit 2; }

if [ ! -x "$VENV/bin/python" ]; then
    echo "bootstrap: creating $VENV with $($PYTHON --version)"
    "$PYTHON" -m venv "$VENV" || {
        echo "bootstrap: venv failed; installing python3-venv" >&2
        apt-get install -y -qq python3-venv >/dev/null && "$PYTHON" -m venv "$VENV"; }
fi
"$VENV/bin/python" -m pip install -q --upgrade pip
# the fast extra (python-lzf) builds from source: without a compiler, install without it (open3d reads those PCDs)
"$VENV/bin/python" -m pip install -q -e ".[test,fast]" 2>/dev/null || "$VENV/bin/python" -m pip install -q -e ".[test]"
"$VENV/bin/python" -c "import open3d, emcee, trimesh, skimage, igl, ezdxf, plotly" \
    || { echo "bootstrap: imports failed after install" >&2; exit 2; }
echo "bootstrap: ready ($VENV)"
