"""`trackpilot upload TRACK`: put a track on a running board, verified, without a reset.
`trackpilot upload --config FILE`: install configuration settings (e.g. `trackpilot tune`'s
config.json) the same way: validated here with the firmware's own schema, merged over the board's
/config.json, the merged file validated again, copied, verified and renamed over /config.json (the
old one kept as /config.previous.json); only in STANDBY (the maintenance state's rule). The
firmware reads its configuration at start-up: the settings take effect at the next reset.

    trackpilot upload tracks/middelburg_loop.csv [--port PORT]
    trackpilot upload --config tune_out/config.json [--port PORT]

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
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from trackpilot_tools.device_cmd import Device, DeviceError, add_device_args, file_digest
from trackpilot_tools.mpy import FIRMWARE_DIR

CONFIG = "config.json"
CONFIG_PREVIOUS = "config.previous.json"
CONFIG_TEMP = "config.upload.tmp"
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


def _fw_config():
    if str(FIRMWARE_DIR) not in sys.path:
        sys.path.insert(0, str(FIRMWARE_DIR))
    from trackpilot import config as fwconfig

    return fwconfig


def check_config(path):
    """The settings of a partial configuration file, validated; DeviceError with every mistake."""
    fwconfig = _fw_config()
    try:
        cfg = json.loads(Path(path).read_text())
    except OSError as e:
        raise DeviceError("cannot read %s: %s" % (path, e.strerror or e))
    except ValueError as e:
        raise DeviceError("%s is not JSON (%s); not uploaded" % (path, e))
    if not isinstance(cfg, dict) or not all(isinstance(v, dict) for v in cfg.values()):
        raise DeviceError("%s: expected {\"section\": {\"key\": value}}; not uploaded" % path)
    errors = fwconfig.validate(cfg)
    if errors:
        raise DeviceError("%s: %s; not uploaded" % (path, "; ".join(errors)))
    return cfg


def merge_config(current, new):
    out = {sec: dict(body) for sec, body in current.items() if isinstance(body, dict)}
    for sec, body in new.items():
        out.setdefault(sec, {}).update(body)
    return out


def upload_config(dev, path, say=print):
    """Validate, enter maintenance (STANDBY only), merge over the board's configuration, validate
    the result, copy, verify, install, leave. Returns (the board's answer, the merged settings)."""
    fwconfig = _fw_config()
    new = check_config(path)
    say("configuration %s: %d settings in %s: valid" % (
        path, sum(len(b) for b in new.values()), ", ".join(sorted(new))))
    dev.enter()
    try:
        ans = dev.xfer("read_small(%r)" % dev.path(CONFIG))
        if not ans.get("ok"):
            raise DeviceError("cannot read the board's configuration: %s" % ans.get("why"))
        current = {}
        if ans.get("text"):
            try:
                current = json.loads(ans["text"])
            except ValueError:
                current = None
            if not isinstance(current, dict):
                say("warning: the board's %s is not a valid JSON object; the new file starts "
                    "from the defaults plus these settings" % CONFIG)
                current = {}
        merged = merge_config(current, new)
        errors = fwconfig.validate(merged)
        if errors:
            raise DeviceError("the board's configuration with these settings does not validate: %s; "
                              "nothing changed" % "; ".join(errors))
        fd, tmp = tempfile.mkstemp(suffix=".json")
        try:
            with os.fdopen(fd, "w") as f:
                f.write(json.dumps(merged, indent=1, sort_keys=True))
            size = Path(tmp).stat().st_size
            digest = file_digest(tmp, dev.xfer("info()")["algo"])
            dev.copy_to(tmp, dev.path(CONFIG_TEMP))
        finally:
            os.unlink(tmp)
        ans = dev.xfer("install(%r, %r, %d, %r, %r)" % (
            dev.path(CONFIG_TEMP), dev.path(CONFIG), size, digest, dev.path(CONFIG_PREVIOUS)))
        if not ans.get("ok"):
            raise DeviceError("the board refused the configuration: %s" % ans.get("why"))
        say("verified on the board and installed as %s%s" % (
            dev.path(CONFIG), "; the previous one is kept as %s" % ans["kept"] if ans.get("kept") else ""))
        return ans, merged
    finally:
        try:
            dev.leave()
        except DeviceError as e:
            say("warning: could not end maintenance (%s); it ends by itself after its idle time" % e)


def _run(args):
    if bool(args.track) == bool(args.config):
        print("trackpilot upload: give a TRACK or --config FILE (one of them)", file=sys.stderr)
        return 2
    try:
        dev = Device(args.port, args.device_root)
        if args.config:
            upload_config(dev, args.config)
            print("the firmware reads its configuration at start-up: the settings take effect at "
                  "the next reset (power-cycle the board in STANDBY)")
            return 0
        upload(dev, args.track)
        print("the app picks the track up now, in STANDBY (engaging stays a person's decision)")
        return 0
    except DeviceError as e:
        print("trackpilot upload: %s" % e, file=sys.stderr)
        return 1


def add_parser(p):
    p.add_argument("track", nargs="?", help="track CSV file (tracks/README.md)")
    p.add_argument("--config", metavar="FILE",
                   help="install configuration settings instead (e.g. trackpilot tune's config.json)")
    add_device_args(p)
    p.set_defaults(func=_run)
