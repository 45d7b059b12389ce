"""A MicroPython unix-port "board" on a pseudo-terminal, for driving with the real mpremote
(`trackpilot board-sim` for people, tests/host/test_device_transfer.py for the tests).

Topology: the interpreter's stdin/stdout is the pty MASTER; mpremote opens the SLAVE path
(/dev/pts/N) like a serial port. The slave is in raw mode (no echo, no line editing, no signals),
so Ctrl-C reaches the program as a byte, as it does on the ESP32 with micropython.kbd_intr(-1).
The test keeps its own slave descriptor open (never reading it) so that the master does not see a
hang-up between two mpremote runs; output written while no mpremote is connected waits in the
slave's queue and is flushed by mpremote's next connect.
"""
import os
import subprocess
import tty
from pathlib import Path

from trackpilot_tools.mpy import ROOT

DEVICE_MAIN = ROOT / "tests" / "host" / "_device_main.py"  # the board's main.py stand-in


class PtyBoard:
    def __init__(self, root_dir, args=(), script=None, pythonpath=None):
        from trackpilot_tools.mpy import micropython_cmd

        self.root = Path(root_dir)
        master, slave = os.openpty()
        tty.setraw(slave)
        self.master = master
        self.slave = slave
        self.port = os.ttyname(slave)
        env = dict(os.environ)
        paths = pythonpath or [str(ROOT / "firmware"), str(ROOT / "hmi")]
        env["MICROPYPATH"] = ":".join(paths + [".frozen"])
        script = script or str(DEVICE_MAIN)
        self.proc = subprocess.Popen(micropython_cmd() + [script] + [str(a) for a in args],
                                     stdin=master, stdout=master, stderr=subprocess.PIPE,
                                     cwd=str(self.root), env=env, close_fds=True)

    def events(self):
        try:
            return (self.root / "events.txt").read_text()
        except OSError:
            return ""

    def set_mode(self, mode):
        (self.root / "mode.txt").write_text(mode)

    def alive(self):
        return self.proc.poll() is None

    def close(self):
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(timeout=5)
        err = self.proc.stderr.read().decode(errors="replace")
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass
        return err
