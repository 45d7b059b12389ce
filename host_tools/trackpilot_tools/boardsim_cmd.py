"""`trackpilot board-sim`: a "board" without hardware, to try upload, pull and deploy.

The MicroPython unix port runs the real maintenance loop (trackpilot.maint) around the real
application on the bench wiring (no devices attached), with its stdin/stdout on a pseudo-terminal;
mpremote (and so `trackpilot upload/pull/deploy`) opens the pty like a board's USB serial port.
A folder plays the board's flash (`--root`, default board_sim/): tracks/active.csv, log/ (put logs
there with --logs to try `pull`), appdata/ (the application's own log and state).
"""
import shutil
import signal
import sys
import time
from pathlib import Path

from trackpilot_tools.errors import UserError


def run(args):
    from trackpilot_tools.ptyboard import PtyBoard

    root = Path(args.root).absolute()
    (root / "tracks").mkdir(parents=True, exist_ok=True)
    (root / "log").mkdir(exist_ok=True)
    for p in args.logs or ():
        if not Path(p).is_file():
            raise UserError("no such log: %s" % p)
        shutil.copy(p, root / "log" / Path(p).name)
    (root / "mode.txt").write_text(args.mode)

    def on_term(signum, frame):  # `kill` stops the board too, like Ctrl-C
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_term)
    board = PtyBoard(root, args=[args.mode] + (["--stand-in"] if args.stand_in else []))
    seen = 0
    try:
        t_end = time.monotonic() + 10
        while "RUN app run" not in board.events():
            if not board.alive() or time.monotonic() > t_end:
                raise UserError("the unix-port board did not start: %s"
                                % (board.close().strip().splitlines() or ["no output"])[-1])
            time.sleep(0.1)
        port = board.port
        print("board-sim: a unix-port board in %s mode on %s (flash: %s)" % (args.mode, port, root))
        print("  try:  trackpilot upload tracks/middelburg_loop.csv --port %s --device-root ''" % port)
        print("        trackpilot pull --port %s --device-root '' --out pulled_logs" % port)
        print("        mpremote connect %s  (the maintenance REPL; Ctrl-] leaves)" % port)
        print("  the board's events follow; Ctrl-C stops it", flush=True)
        t_end = time.monotonic() + args.duration if args.duration else None
        while board.alive() and (t_end is None or time.monotonic() < t_end):
            ev = board.events()
            if len(ev) > seen:
                sys.stdout.write("".join("  board: " + ln + "\n" for ln in ev[seen:].splitlines()))
                sys.stdout.flush()
                seen = len(ev)
            time.sleep(0.2)
        if not board.alive():
            print("board-sim: the board stopped", file=sys.stderr)
            return 1
    except KeyboardInterrupt:
        print("\nboard-sim: stopped")
    finally:
        err = board.close()
        if "Traceback" in err:
            sys.stderr.write(err)
    return 0


def add_parser(p):
    p.add_argument("--root", default="board_sim", help="folder playing the board's flash (default board_sim/)")
    p.add_argument("--mode", choices=("STANDBY", "AUTO"), default="STANDBY",
                   help="the application's mode (AUTO: to see maintenance refused while steering); "
                        "change it later by writing STANDBY or AUTO into ROOT/mode.txt")
    p.add_argument("--logs", nargs="+", metavar="FILE", help="log files to put in the board's log/ (for pull)")
    p.add_argument("--stand-in", action="store_true",
                   help="a small stand-in application instead of the real one (starts faster)")
    p.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (default: Ctrl-C)")
    p.set_defaults(func=run)
