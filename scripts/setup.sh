#!/usr/bin/env bash
# Set up wbik in ./.venv: system packages (PyKDL, Chromium) where we can install them,
# then the pinned Python dependencies and the package itself (editable), with uv (pip as a fallback).
# Idempotent: a second run only checks.
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null || PY=python3

apt_install() {
    # PyKDL (orocos KDL's own binding) exists only as a Debian package; Chromium is for the viewer test.
    local missing=()
    for pkg in "$@"; do dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg"); done
    [ ${#missing[@]} -eq 0 ] && return 0
    if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null; then
        echo "setup: apt-get install ${missing[*]}"
        apt-get update -qq >/dev/null
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
    else
        echo "setup: cannot install ${missing[*]} (needs root and apt-get)." >&2
        echo "setup: run 'sudo apt-get install ${missing[*]}'; the 'kdl' method and the browser test need them." >&2
    fi
}
apt_install python3-pykdl chromium chromium-driver

if [ ! -x .venv/bin/python ]; then
    "$PY" -m venv .venv
fi
# what the install step reads: the pins, the package's build files and backend, the kernels' sources, the
# compilers present and WBIK_BUILD_CXX; when none changed since an install that built every kernel, it is
# skipped (the C++ kernel takes about 12 s to compile). --reinstall-package: uv rebuilds an editable
# package only when its build files change, not its kernels' sources.
inputs=$( (cat requirements.lock pyproject.toml setup.py build_backend/*.py wbik/kernels/_*.c wbik/kernels/_*.cpp wbik/kernels/_*.h;
           command -v gcc g++ || true; echo "WBIK_BUILD_CXX=${WBIK_BUILD_CXX:-1}") | sha256sum | cut -c1-16)
if [ "$(cat .venv/.wbik-installed 2>/dev/null)" = "$inputs" ] && .venv/bin/python -c "import wbik" 2>/dev/null; then
    echo "setup: the pinned set and wbik's kernels are installed and up to date"
else
    rm -f .venv/.wbik-installed
    .venv/bin/python -m pip install -q --upgrade pip >/dev/null
    # uv installs the pinned set in about a third of pip's time (it links files from its cache instead of
    # unpacking every wheel; --system-certs: the system's CA store, as pip.conf's cert gives pip); pip does
    # it where uv cannot be installed or fails
    if .venv/bin/python -m pip install -q -c requirements.lock uv \
            && .venv/bin/uv pip install -q --system-certs --python .venv/bin/python --compile-bytecode \
                -c requirements.lock --build-constraints requirements.lock --reinstall-package wbik \
                -e ".[all,dev]"; then
        :
    else
        echo "setup: uv could not install the pinned set; installing with pip" >&2
        .venv/bin/python -m pip install -q -c requirements.lock -e ".[all,dev]"
    fi
    if .venv/bin/python -c "from wbik.kernels.twins import KERNELS; raise SystemExit(not all(k.extension for k in KERNELS))"; then
        echo "$inputs" > .venv/.wbik-installed  # every kernel built: the next run may skip this step
    fi
fi

# Expose Debian's PyKDL (built for CPython 3.11) to the venv without pulling in the rest of
# /usr/lib/python3/dist-packages: a shim folder holding only PyKDL, added through a .pth file.
site=$(.venv/bin/python -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
kdl_so=$(ls /usr/lib/python3/dist-packages/PyKDL*.so 2>/dev/null | head -n 1 || true)
if [ -n "$kdl_so" ]; then
    mkdir -p .venv/pykdl-shim
    ln -sf "$kdl_so" .venv/pykdl-shim/
    echo "$(pwd)/.venv/pykdl-shim" > "$site/wbik-pykdl.pth"
fi
# the notebooks: each notebooks/NN_name.py (a jupytext percent script, the tested source) is paired with the
# NN_name.ipynb that JupyterLab opens (notebooks/jupytext.toml); saving either one updates the other
.venv/bin/jupytext --quiet --sync notebooks/[0-9][0-9]_*.py
missing=$(.venv/bin/python -c "from wbik.kernels.twins import KERNELS; print(' '.join(k.name for k in KERNELS if k.extension is None))")
if [ -n "$missing" ]; then
    echo "setup: these optional compiled kernels were not built: $missing (no C or C++ compiler, no Python" >&2
    echo "setup: headers, or WBIK_BUILD_CXX=0 for chain_fk): wbik runs their Python twins (slower; solve gives" >&2
    echo "setup: the same bits); install gcc, g++ and python3-dev, then run this again." >&2
fi
.venv/bin/python -c "import wbik; print('setup: wbik', wbik.__version__, 'ready in .venv')"
