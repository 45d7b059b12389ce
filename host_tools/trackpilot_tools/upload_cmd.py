"""`trackpilot upload TRACK`: put a track on a running board, verified, without a reset.

    trackpilot upload tracks/middelburg_loop.csv [--port PORT]

Steps (each one printed):
  1. validate the file with the firmware's own track module (firmware/trackpilot/nav/track.py, run
     here under CPython): a file that does not parse is refused with its line and message and the
     board is not touched; warnings are printed;
  2. ask the board for the maintenance state (refused unless it is in STANDBY: the reason is shown);
  3. copy through mpremote to /tracks/upload.tmp;
  4. the board checks size and sha256 (CRC32 without hashlib) against what was sent, keeps the
     current track as /tracks/previous.csv and renames the upload over /tracks/active.csv; a
     mismatch removes the temporary file and changes nothing;
  5. end maintenance: the app restarts without a reset, in STANDBY, and loads the new track.
"""
import sys
import time
from pathlib import Path

from trackpilot_tools.device_cmd import Device, DeviceError, add_device_args, file_digest
from trackpilot_tools.mpy import FIRMWARE_DIR

ACTIVE = "tracks/active.csv"
PREVIOUS = "tracks/previous.csv"
TEMP = "tracks/upload.tmp"


def check_track(path):
    """(text, warnings) or raises DeviceError with the parser's message."""
    if str(FIRMWARE_DIR) not in sys.path:
        sys.path.insert(0, str(FIRMWARE_DIR))
    from trackpilot.nav import track as fw_track

    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise DeviceError("cannot read %s: %s" % (path, e))
    try:
        trk = fw_track.parse_track_csv(data)
    except fw_track.TrackError as e:
        raise DeviceError("%s: %s; not uploaded" % (path, e))
    return trk, fw_track.validate(trk, None)


def upload(dev, path, before_install=None, say=print):
    """Validate, enter maintenance, copy, verify on the board, install, leave. Returns the
    board's answer dict. before_install(dev) runs between copy and verify (tests use it to
    corrupt the temporary file)."""
    trk, warnings = check_track(path)
    size = Path(path).stat().st_size
    say("track %s: %d waypoints, %.0f m, %d bytes: valid" % (path, len(trk.waypoints), trk.length_m, size))
    for w in warnings:
        say("  warning: " + w)
    dev.enter()
    try:
        info = dev.xfer("info()")
        algo = info["algo"]
        digest = file_digest(path, algo)
        dev.xfer("mkdirs(%r)" % dev.path("tracks"))
        t0 = time.monotonic()
        dev.copy_to(path, dev.path(TEMP))
        dt = time.monotonic() - t0
        say("copied %d bytes to %s in %.2f s" % (size, dev.path(TEMP), dt))
        if before_install is not None:
            before_install(dev)
        ans = dev.xfer("install(%r, %r, %d, %r, %r)" % (
            dev.path(TEMP), dev.path(ACTIVE), size, digest, dev.path(PREVIOUS)))
        if not ans.get("ok"):
            raise DeviceError("the board refused the upload: %s" % ans.get("why"))
        say("verified on the board (%s %s...) and installed as %s%s" % (
            algo, digest[:16], dev.path(ACTIVE),
            "; the previous track is kept as %s" % ans["kept"] if ans.get("kept") else ""))
        return ans
    finally:
        try:
            dev.leave()
        except DeviceError as e:
            say("warning: could not end maintenance (%s); it ends by itself after its idle time" % e)


def _run(args):
    try:
        dev = Device(args.port, args.device_root)
        upload(dev, args.track)
        print("the app picks the track up now, in STANDBY (engaging stays a person's decision)")
        return 0
    except DeviceError as e:
        print("trackpilot upload: %s" % e, file=sys.stderr)
        return 1


def add_parser(p):
    p.add_argument("track", help="track CSV file (tracks/README.md)")
    add_device_args(p)
    p.set_defaults(func=_run)
