#!/usr/bin/env bash
# Set up everything the project needs on a fresh machine: the system tools the tests use (poppler's
# pdfsig/pdftoppm/pdftotext and NSS's certutil, to check certificates with independent software;
# Xvfb and Qt's xcb libraries for the 3D viewport; installed with apt-get when run as root) and a virtual environment in .venv with the pinned
# versions of constraints.txt (so a certificate issued today can be reproduced).
set -euo pipefail
cd "$(dirname "$0")/.."

need_apt=()
command -v pdfsig >/dev/null 2>&1 || need_apt+=(poppler-utils)
command -v certutil >/dev/null 2>&1 || need_apt+=(libnss3-tools)
# The desktop app's 3D viewport tests run on a virtual X display with Qt's xcb platform;
# libusb is what Open3D (the optional bench extra, benchmarks/bench_open3d.py) loads.
command -v xvfb-run >/dev/null 2>&1 || need_apt+=(xvfb xauth)
for lib in libxcb-icccm4 libxcb-image0 libxcb-keysyms1 libxcb-randr0 libxcb-render-util0 \
           libxcb-shape0 libxcb-xinerama0 libxcb-xkb1 libxkbcommon-x11-0 libxcb-cursor0 \
           libgl1 libegl1 libgl1-mesa-dri libusb-1.0-0; do
    dpkg -s "$lib" >/dev/null 2>&1 || need_apt+=("$lib")
done
if [ ${#need_apt[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "setup: installing ${need_apt[*]} (apt-get)" >&2
        export DEBIAN_FRONTEND=noninteractive
        apt-get install -y -q --no-install-recommends "${need_apt[@]}" >/dev/null 2>&1 || {
            apt-get update -q >/dev/null
            apt-get install -y -q --no-install-recommends "${need_apt[@]}" >/dev/null
        }
    else
        echo "setup: note: ${need_apt[*]} missing; the certificate and 3D view tests need them" \
             "(run this script as root, or: sudo apt-get install ${need_apt[*]})" >&2
    fi
fi

PYTHON=${PYTHON:-python3}
if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
    echo "setup: Python 3.11 or newer is needed ($PYTHON is $("$PYTHON" --version 2>&1))" >&2
    exit 1
fi
if [ ! -x .venv/bin/python ]; then
    "$PYTHON" -m venv .venv
fi
# Reinstall only when the declared dependencies changed since the last setup.
stamp=$(cat pyproject.toml constraints.txt | sha256sum | cut -d' ' -f1)
if [ "$(cat .venv/.qa-setup-stamp 2>/dev/null)" != "$stamp" ]; then
    .venv/bin/python -m pip install --quiet --disable-pip-version-check \
        -c constraints.txt -e '.[test]'
    echo "$stamp" > .venv/.qa-setup-stamp
fi
