#!/usr/bin/env bash
# Bootstrap fmr-editor on a fresh Debian/Ubuntu machine. Idempotent: a repeat run takes a second.
#   1. system packages (as root: installs the missing ones; otherwise: says what to install)
#   2. .venv in the repository root with Python >= 3.11
#   3. pip install -e '.[test]', skipped while .venv/.setup-stamp matches pyproject.toml
#   4. the engine's compiled kernels into numba's cache, skipped while none of the engine's sources changed
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
REPO="$(pwd)"
VENV="$REPO/.venv"
STAMP="$VENV/.setup-stamp"

say() { printf 'setup: %s\n' "$*"; }
die() { printf 'setup: error: %s\n' "$*" >&2; exit 1; }

# A Python that is >= 3.11 and can make a venv (Debian's python3 needs python3-venv for ensurepip).
python_ok() {
    "$1" -c 'import sys, venv, ensurepip; sys.exit(sys.version_info < (3, 11))' >/dev/null 2>&1
}

find_python() {
    local cand
    for cand in python3.11 python3; do
        if command -v "$cand" >/dev/null 2>&1 && python_ok "$cand"; then
            printf '%s\n' "$cand"
            return 0
        fi
    done
    return 1
}

# --- 1. system packages -------------------------------------------------------------------------
# Libraries for Qt (xcb platform), OpenGL and a virtual X server for the editor and its GUI tests.
SYSTEM_PACKAGES=(xvfb libegl1 libgl1 libglib2.0-0 libxkbcommon-x11-0 libxcb-cursor0 libxcb-icccm4
    libxcb-keysyms1 libxcb-shape0 libfontconfig1 libdbus-1-3
    libgomp1     # OpenMP for numba: its fallback thread pool aborts when two threads run kernels at once
    librsvg2-bin)  # rsvg-convert: the tests render exported SVG with a third-party renderer
if ! find_python >/dev/null; then
    # No usable Python (e.g. pyenv's) on PATH: take Debian's.
    SYSTEM_PACKAGES=(python3 python3-venv python3-pip "${SYSTEM_PACKAGES[@]}")
fi

installed() {
    # Newer releases renamed some libraries with a t64 suffix (libglib2.0-0t64).
    local name
    for name in "$1" "$1t64"; do
        if dpkg-query -W -f='${db:Status-Abbrev}' "$name" 2>/dev/null | grep -q '^ii'; then
            return 0
        fi
    done
    return 1
}

if command -v dpkg-query >/dev/null 2>&1; then
    missing=()
    for pkg in "${SYSTEM_PACKAGES[@]}"; do
        installed "$pkg" || missing+=("$pkg")
    done
    if ((${#missing[@]})); then
        if [[ "$(id -u)" -eq 0 ]] && command -v apt-get >/dev/null 2>&1; then
            say "installing system packages: ${missing[*]}"
            export DEBIAN_FRONTEND=noninteractive
            if ! { apt-get update -qq && apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null; }; then
                say "WARNING: apt-get failed; the Qt editor and GUI tests may not work without: ${missing[*]}" >&2
            fi
        else
            say "NOTE: missing system packages (needed for the Qt editor and GUI tests); install with:"
            say "    sudo apt-get install --no-install-recommends ${missing[*]}"
        fi
    fi
else
    say "NOTE: not a Debian/Ubuntu system; make sure Python >= 3.11 with venv, Xvfb, and the"
    say "      OpenGL/xcb libraries Qt needs are installed."
fi

# --- 2. virtual environment ---------------------------------------------------------------------
venv_ok() {
    "$VENV/bin/python" -c 'import sys; sys.exit(sys.version_info < (3, 11))' >/dev/null 2>&1
}
if ! venv_ok; then
    PYTHON="$(find_python)" || die "need Python >= 3.11 with the venv module (python3.11 or python3 on PATH); found: $(python3 --version 2>&1 || echo none)"
    say "creating .venv with $("$PYTHON" -c 'import sys; print(sys.executable, sys.version.split()[0])')"
    rm -rf "$VENV"
    "$PYTHON" -m venv "$VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --upgrade pip
fi

# --- 3. project and its dependencies ------------------------------------------------------------
# The stamp holds a hash of pyproject.toml and the venv's Python version: while both match and the
# entry points exist, the install is current.
want="$({ cat pyproject.toml; "$VENV/bin/python" -c 'import sys; print(sys.version)'; } | sha256sum | cut -d' ' -f1)"
if ! [[ -f "$STAMP" && "$(cat "$STAMP")" == "$want" && -x "$VENV/bin/fmr-editor" && -x "$VENV/bin/pytest" ]]; then
    say "installing fmr-editor and its dependencies into .venv (the first time takes a few minutes)"
    rm -f "$STAMP"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -e '.[test]' \
        || die "pip install -e '.[test]' failed (see above)"
    printf '%s\n' "$want" >"$STAMP"
    say "ready: $VENV"
fi

# --- 4. bytecode and compiled kernels -----------------------------------------------------------
# An editable install leaves the package's bytecode to its first import, which PYTHONDONTWRITEBYTECODE (or a
# read-only checkout) turns into compiling every module in every process: 0.2-0.5 s of each start.
"$VENV/bin/python" -m compileall -q fmr_editor >/dev/null || die "compiling fmr_editor's bytecode failed"
# Numba compiles a kernel on its first use and caches it beside its source (fmr_editor/**/__pycache__); its
# cache is valid while the source's time and size are. The stamp holds those of every engine source and the
# Python version; it lives in the cache's own folder, so that deleting the caches deletes it too.
KERNEL_STAMP="$REPO/fmr_editor/engine/__pycache__/compiled-kernels.stamp"
kernels="$({ find fmr_editor/engine -name '*.py' -print0 | sort -z | xargs -0 stat -c '%n %Y %s'; \
    "$VENV/bin/python" -c 'import sys; print(sys.version)'; } | sha256sum | cut -d' ' -f1)"
if [[ ! -f "$KERNEL_STAMP" || "$(cat "$KERNEL_STAMP")" != "$kernels" ]]; then
    say "compiling the engine's kernels, once (2-4 minutes of one core, shared out over $(nproc) cores)"
    rm -f "$KERNEL_STAMP"
    "$VENV/bin/python" -m fmr_editor.engine.compile_kernels \
        || die "compiling the engine's kernels failed (see above)"
    mkdir -p "$(dirname "$KERNEL_STAMP")"
    printf '%s\n' "$kernels" >"$KERNEL_STAMP"
fi
