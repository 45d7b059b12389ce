"""`trackpilot pull`: fetch the board's logs, resumably and verified.

    trackpilot pull [--port PORT] [--out DIR] [--delete-after] [--max-bytes N]

For every regular file in /log (the board lists name, size and sha256, or CRC32 without hashlib):
  * DIR/NAME exists with the same size and digest: skipped (nothing is transferred);
  * DIR/NAME.part (an interrupted pull) or an older, shorter DIR/NAME: the board hashes the same
    prefix; if it matches, only the rest is fetched (by byte range), else the file starts over
    (an unmatched local file is kept as NAME.mismatch);
  * bytes arrive as base64 lines that are appended to DIR/NAME.part as they come, so a broken link
    loses at most one line; at the end the whole file's digest must equal the board's, then
    NAME.part becomes NAME.
Nothing is deleted on the board unless --delete-after, and then only files verified here whose
size and digest the board still has.
--max-bytes stops after about N bytes (a slow link: the next run continues).
"""
import binascii
import os
import sys
import time
import zlib
from pathlib import Path

from trackpilot_tools.device_cmd import Device, DeviceError, add_device_args, file_digest

LOG_DIR = "log"


class PullStats:
    def __init__(self):
        self.files = 0
        self.skipped = 0
        self.fetched = 0
        self.resumed = 0
        self.bytes = 0
        self.deleted = 0
        self.incomplete = 0
        self.seconds = 0.0


def _progress(name, done, total, t0):
    if not sys.stderr.isatty():
        return
    rate = done / max(1e-3, time.monotonic() - t0)
    sys.stderr.write("\r  %-24s %9d / %9d B  %6.1f kB/s" % (name, done, total, rate / 1000))
    if done >= total:
        sys.stderr.write("\n")
    sys.stderr.flush()


def fetch_range(dev, remote, part, offset, size, budget, name):
    """Append bytes [offset, size) of remote to part (at most `budget` bytes; None = all).
    Returns bytes received."""
    length = size - offset if budget is None else min(size - offset, budget)
    got = 0
    crc = 0
    t0 = time.monotonic()
    with open(part, "ab") as f:
        f.truncate(offset)  # drop a half-written tail from an earlier run
        code = "import trackpilot.board.xfer as x; x.read_range(%r, %d, %d)" % (remote, offset, length)
        end_seen = None
        for line in dev.stream_lines(code):
            if line.startswith("D "):
                _, off, b64 = line.split(" ", 2)
                if int(off) != offset + got:
                    raise DeviceError("%s: chunk at %s, expected %d" % (name, off, offset + got))
                data = binascii.a2b_base64(b64)
                f.write(data)
                f.flush()
                crc = zlib.crc32(data, crc)
                got += len(data)
                _progress(name, offset + got, size, t0)
            elif line.startswith("E "):
                parts = line.split(" ", 2)
                if parts[1] == "-1":
                    raise DeviceError("%s: %s" % (name, parts[2]))
                end_seen = (int(parts[1]), parts[2])
        os.fsync(f.fileno())
    if end_seen is None:
        raise DeviceError("%s: the transfer ended early at %d bytes (kept as %s; run pull again)"
                          % (name, offset + got, part.name))
    if end_seen[0] != offset + got or end_seen[1] != "%08x" % crc:
        raise DeviceError("%s: range check failed (board: end %d crc %s; here: %d %08x)"
                          % (name, end_seen[0], end_seen[1], offset + got, crc))
    return got


def pull(dev, out_dir, delete_after=False, max_bytes=None, say=print):
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    st = PullStats()
    t_start = time.monotonic()
    dev.enter()
    try:
        ans = dev.xfer("ls(%r)" % dev.path(LOG_DIR), timeout=600)
        if "error" in ans:
            raise DeviceError(ans["error"])
        algo = ans["algo"]
        verified = []
        budget = max_bytes
        for name, size, digest in ans["files"]:
            st.files += 1
            remote = dev.path(LOG_DIR + "/" + name)
            final = out_dir / name
            part = out_dir / (name + ".part")
            if final.exists() and final.stat().st_size == size and file_digest(final, algo) == digest:
                st.skipped += 1
                verified.append((remote, size, digest))
                continue
            offset = 0
            # a local prefix (interrupted pull, or a file that has grown on the board since)
            base = part if part.exists() else (final if final.exists() else None)
            if base is not None and 0 < base.stat().st_size <= size:
                n = base.stat().st_size
                theirs = dev.xfer("digest(%r, %d)" % (remote, n))
                if theirs.get("digest") == file_digest(base, algo, n) and theirs.get("size") == n:
                    if base is final:
                        os.replace(final, part)
                    offset = n
                else:
                    os.replace(base, out_dir / (name + ".mismatch"))
                    say("  %s: local copy differs from the board; kept as %s.mismatch" % (name, name))
            elif base is not None and base.stat().st_size > size:
                os.replace(base, out_dir / (name + ".mismatch"))
                say("  %s: local copy is longer than the board's; kept as %s.mismatch" % (name, name))
            if budget is not None and budget <= 0:
                st.incomplete += 1
                continue
            if offset:
                st.resumed += 1
            got = fetch_range(dev, remote, part, offset, size, budget, name) if size > offset else 0
            if size == 0:
                part.touch()
            st.bytes += got
            if budget is not None:
                budget -= got
            if offset + got < size:
                st.incomplete += 1
                say("  %s: %d of %d bytes so far (--max-bytes); run pull again to continue" % (
                    name, offset + got, size))
                continue
            if file_digest(part, algo) != digest:
                bad = out_dir / (name + ".bad")
                os.replace(part, bad)
                raise DeviceError("%s: %s of the fetched file differs from the board's; kept as %s, "
                                  "run pull again" % (name, algo, bad.name))
            os.replace(part, final)
            st.fetched += 1
            verified.append((remote, size, digest))
            say("  %-24s %9d B %s (%s verified)" % (name, size, "resumed" if offset else "fetched", algo))
        if delete_after:
            for remote, size, digest in verified:
                r = dev.xfer("remove_verified(%r, %d, %r)" % (remote, size, digest))
                if r.get("ok"):
                    st.deleted += 1
                else:
                    say("  %s not deleted: %s" % (remote, r.get("why")))
    finally:
        try:
            dev.leave()
        except DeviceError as e:
            say("warning: could not end maintenance (%s); it ends by itself after its idle time" % e)
    st.seconds = time.monotonic() - t_start
    say("%d files on the board: %d already here, %d fetched (%d resumed), %d incomplete, "
        "%d bytes in %.1f s%s" % (st.files, st.skipped, st.fetched, st.resumed, st.incomplete,
                                   st.bytes, st.seconds,
                                   ", %d deleted on the board" % st.deleted if delete_after else ""))
    return st


def _run(args):
    try:
        dev = Device(args.port, args.device_root)
        st = pull(dev, args.out, args.delete_after, args.max_bytes)
        return 2 if st.incomplete else 0
    except DeviceError as e:
        print("trackpilot pull: %s" % e, file=sys.stderr)
        return 1


def add_parser(p):
    add_device_args(p)
    p.add_argument("--out", default="logs", help="local folder (default logs/)")
    p.add_argument("--delete-after", action="store_true",
                   help="delete each log on the board once it is verified here")
    p.add_argument("--max-bytes", type=int, default=None,
                   help="stop after about this many bytes (continue with the next run)")
    p.set_defaults(func=_run)
