"""Find and run the MicroPython interpreter that executes firmware code on the host.

The `MICROPYTHON` environment variable chooses the interpreter (a path or a command, may carry
options such as `-X heapsize=110000`); the default is the `micropython` the project installs
into its virtualenv, then one on PATH.
"""
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE_DIR = ROOT / "firmware"
HMI_DIR = ROOT / "hmi"


def micropython_cmd():
    """The interpreter command as an argv list."""
    chosen = os.environ.get("MICROPYTHON")
    if chosen:
        return shlex.split(chosen)
    beside = Path(sys.executable).parent / "micropython"
    if beside.exists():
        return [str(beside)]
    venv = ROOT / ".venv" / "bin" / "micropython"
    if venv.exists():
        return [str(venv)]
    found = shutil.which("micropython")
    if found:
        return [found]
    raise RuntimeError("no MicroPython interpreter: run `make setup` or set MICROPYTHON")


def micropython_env(extra_paths=()):
    """Environment with MICROPYPATH pointing at the firmware and HMI code."""
    env = dict(os.environ)
    paths = [str(p) for p in extra_paths] + [str(FIRMWARE_DIR), str(HMI_DIR), ".frozen"]
    env["MICROPYPATH"] = ":".join(paths)
    return env


def run_script(script, args=(), stdin_bytes=None, extra_paths=(), timeout=600, check=True):
    """Run a MicroPython script (path) with args; returns CompletedProcess (bytes)."""
    proc = subprocess.run(
        micropython_cmd() + [str(script)] + [str(a) for a in args],
        input=stdin_bytes,
        env=micropython_env(extra_paths),
        capture_output=True,
        timeout=timeout,
    )
    if check and proc.returncode != 0:
        raise RuntimeError(
            "MicroPython script %s failed (%d):\n%s%s"
            % (script, proc.returncode, proc.stdout.decode(errors="replace")[-2000:],
               proc.stderr.decode(errors="replace")[-4000:])
        )
    return proc


def popen_script(script, args=(), extra_paths=(), **kw):
    """Start a MicroPython script with pipes (for lockstep simulation)."""
    return subprocess.Popen(
        micropython_cmd() + [str(script)] + [str(a) for a in args],
        env=micropython_env(extra_paths),
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        **kw
    )
