"""Device-side helpers for host transfers (`trackpilot upload`, `pull`, `deploy`).

The host runs these through mpremote's raw REPL (`mpremote connect PORT resume exec ...`), during
the maintenance state (maint.py). Every answer is ONE line `XFER <repr>` that the host parses with
`ast.literal_eval`, or a stream of `D`/`E` lines (read_range), so output from anything else on the
console cannot be mistaken for an answer.

Checksums: sha256 (hashlib) where the firmware has it, else CRC32 (binascii); `algo()` says which.
The host computes the same over the bytes it sent or received.

Usage (what the host sends):
    import trackpilot.board.xfer as x; x.info()
    x.install("/tracks/upload.tmp", "/tracks/active.csv", 812, "ab12...", "/tracks/previous.csv")
    x.ls("/log")                       # [(name, size, digest)] of regular files
    x.digest("/log/0003-00.tpl", 4096) # digest of the first 4096 bytes (resume check)
    x.read_range("/log/0003-00.tpl", 4096, 65536)
"""
import sys

try:
    import os
except ImportError:  # pragma: no cover
    import uos as os

try:
    import hashlib

    _HAVE_SHA = hasattr(hashlib, "sha256")
except ImportError:  # pragma: no cover
    _HAVE_SHA = False

import binascii

CHUNK = 512  # bytes read at a time: small, so hashing a big log needs no big buffer
LINE = 384  # bytes per D line of read_range (512 base64 chars)


def algo():
    return "sha256" if _HAVE_SHA else "crc32"


def _answer(obj):
    print("XFER", repr(obj))


class _Hasher:
    def __init__(self):
        if _HAVE_SHA:
            self.h = hashlib.sha256()
            self.crc = None
        else:
            self.h = None
            self.crc = 0

    def update(self, data):
        if self.h is not None:
            self.h.update(data)
        else:
            self.crc = binascii.crc32(data, self.crc)

    def hexdigest(self):
        if self.h is not None:
            return binascii.hexlify(self.h.digest()).decode()
        return "%08x" % (self.crc & 0xFFFFFFFF)


def _digest(path, length=-1):
    """(bytes hashed, hex digest) of the first `length` bytes (-1: all)."""
    h = _Hasher()
    buf = bytearray(CHUNK)
    mv = memoryview(buf)
    n_total = 0
    with open(path, "rb") as f:
        while length < 0 or n_total < length:
            want = CHUNK if length < 0 else min(CHUNK, length - n_total)
            n = f.readinto(mv[:want])
            if not n:
                break
            h.update(mv[:n])
            n_total += n
    return n_total, h.hexdigest()


def _size(path):
    return os.stat(path)[6]


def _is_file(path):
    try:
        return os.stat(path)[0] & 0x4000 == 0
    except OSError:
        return False


def info():
    """Answer: checksum algorithm, .mpy version, platform, maintenance status."""
    st = "?"
    try:
        from trackpilot.board import maint

        st = maint.status()
    except ImportError:
        pass
    _answer({"algo": algo(), "mpy": getattr(sys.implementation, "_mpy", 0), "platform": sys.platform,
             "maint": st})


def digest(path, length=-1):
    try:
        n, d = _digest(path, length)
        _answer({"path": path, "size": n, "digest": d, "algo": algo()})
    except OSError as e:
        _answer({"path": path, "error": "cannot read: %s" % e})


def _rename_over(src, dst):
    """Atomic replace where the filesystem allows it (littlefs, POSIX); else remove + rename."""
    try:
        os.rename(src, dst)
    except OSError:
        try:
            os.remove(dst)
        except OSError:
            pass
        os.rename(src, dst)


def _copy(src, dst):
    tmp = dst + ".tmp"
    buf = bytearray(CHUNK)
    mv = memoryview(buf)
    with open(src, "rb") as fi:
        with open(tmp, "wb") as fo:
            while True:
                n = fi.readinto(buf)
                if not n:
                    break
                fo.write(mv[:n])
    _rename_over(tmp, dst)


def read_small(path, limit=8192):
    """A small text file (the configuration) as {"ok", "text"}; text None when there is none."""
    try:
        with open(path) as f:
            text = f.read(limit + 1)
    except OSError:
        _answer({"ok": True, "text": None})
        return
    except Exception as e:  # not UTF-8: the host treats it as no usable file
        _answer({"ok": True, "text": None, "why": str(e)})
        return
    if len(text) > limit:
        _answer({"ok": False, "why": "%s is larger than %d bytes" % (path, limit)})
        return
    _answer({"ok": True, "text": text})


def install(tmp, dest, size, want_digest, keep=None):
    """Verify the uploaded temporary file, then put it in place.

    Order (the active file exists at every moment): verify tmp (size and digest; on a mismatch
    remove tmp and change nothing); copy the active file to `keep` (via keep.tmp + rename);
    rename tmp over dest. Answer: {"ok", "why", "kept", "digest"}."""
    try:
        n, d = _digest(tmp)
    except OSError as e:
        _answer({"ok": False, "why": "uploaded file %s unreadable: %s" % (tmp, e)})
        return
    if n != size or d != want_digest:
        try:
            os.remove(tmp)
        except OSError:
            pass
        _answer({"ok": False, "why": "checksum mismatch: device has %d bytes %s %s, host sent %d "
                 "bytes %s; nothing changed" % (n, algo(), d, size, want_digest)})
        return
    kept = None
    if keep and _is_file(dest):
        try:
            _copy(dest, keep)
            kept = keep
        except OSError as e:
            _answer({"ok": False, "why": "could not keep %s as %s: %s; nothing changed" % (dest, keep, e)})
            return
    try:
        _rename_over(tmp, dest)
    except OSError as e:
        _answer({"ok": False, "why": "rename %s -> %s failed: %s" % (tmp, dest, e)})
        return
    _answer({"ok": True, "why": "installed", "kept": kept, "digest": d, "size": n})


def ls(folder):
    """Regular files in `folder`: answer [(name, size, digest)], sorted by name."""
    out = []
    try:
        names = sorted(os.listdir(folder))
    except OSError as e:
        _answer({"error": "cannot list %s: %s" % (folder, e)})
        return
    for name in names:
        path = folder.rstrip("/") + "/" + name if folder not in ("", ".") else name
        if not _is_file(path):
            continue
        try:
            n, d = _digest(path)
        except OSError:
            continue
        out.append((name, n, d))
    _answer({"files": out, "algo": algo()})


def read_range(path, offset, length=-1):
    """Stream bytes [offset, offset+length) as lines `D <offset> <base64>`, then
    `E <end offset> <crc32 of the streamed bytes>`; the host appends each D line to its partial
    file as it arrives, so a broken link loses at most one line."""
    buf = bytearray(LINE)
    mv = memoryview(buf)
    pos = offset
    crc = 0
    end = -1 if length < 0 else offset + length
    try:
        f = open(path, "rb")
    except OSError as e:
        print("E -1 cannot open %s: %s" % (path, e))
        return
    with f:
        f.seek(offset)
        while end < 0 or pos < end:
            want = LINE if end < 0 else min(LINE, end - pos)
            n = f.readinto(mv[:want])
            if not n:
                break
            crc = binascii.crc32(mv[:n], crc)
            sys.stdout.write("D %d %s" % (pos, binascii.b2a_base64(mv[:n]).decode()))
            pos += n
    print("E %d %08x" % (pos, crc & 0xFFFFFFFF))


def remove_verified(path, size, want_digest):
    """Delete a log the host has verified: only when the device still has exactly those bytes."""
    try:
        n, d = _digest(path)
    except OSError as e:
        _answer({"ok": False, "why": "cannot read: %s" % e})
        return
    if n != size or d != want_digest:
        _answer({"ok": False, "why": "file changed since the pull (%d bytes %s); kept" % (n, d)})
        return
    os.remove(path)
    _answer({"ok": True, "why": "removed"})


def remove(path):
    """Remove a file if it exists (the host clears a stale temporary upload)."""
    try:
        os.remove(path)
        _answer({"ok": True})
    except OSError:
        _answer({"ok": False})


def mkdirs(*paths):
    for p in paths:
        try:
            os.mkdir(p)
        except OSError:
            pass
    _answer({"ok": True})
