"""The `trackpilot` command. Each command group lives in its own module with `add_parser(sub)`;
the module is imported only when listed here, so one broken tool cannot break the others."""
import argparse
import importlib
import sys

# (command, module, help)
COMMANDS = [
    ("track", "trackpilot_tools.track_cmd", "check and import tracks"),
    ("gnss", "trackpilot_tools.gnss_cmd", "decode raw GNSS captures with the firmware's parser"),
    ("seatalk", "trackpilot_tools.seatalk_cmd", "decode SeaTalk1 captures with the firmware's parser"),
    ("sim", "trackpilot_tools.sim_cmd", "sail a track with the real firmware against a simulated boat"),
    ("bench", "trackpilot_tools.bench_cmd", "accuracy, compute and fault benchmark"),
    ("log", "trackpilot_tools.log_cmd", "decode and plot firmware logs"),
    ("replay", "trackpilot_tools.replay_cmd", "replay a log through the firmware core"),
    ("tune", "trackpilot_tools.tune_cmd", "fit the boat from a commissioning trial's log; tuned config"),
    ("monitor", "trackpilot_tools.monitor_cmd", "live view of the boat from its telemetry"),
    ("hmi", "trackpilot_tools.hmi_cmd", "preview the HMI pages"),
    ("deploy", "trackpilot_tools.device_cmd", "install the firmware on an ESP32"),
    ("upload", "trackpilot_tools.upload_cmd", "put a track on a running board (maintenance state, verified)"),
    ("pull", "trackpilot_tools.pull_cmd", "fetch the board's logs, resumably and verified"),
    ("board-sim", "trackpilot_tools.boardsim_cmd", "a unix-port board on a pseudo-terminal to try upload/pull/deploy"),
]


def build_parser():
    parser = argparse.ArgumentParser(
        prog="trackpilot",
        description="trackpilot host tools: tracks, firmware, logs, replay, live monitor, simulator "
                    "(README.md). Commands that run firmware code use $MICROPYTHON.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, modname, helptext in COMMANDS:
        try:
            mod = importlib.import_module(modname)
        except ImportError as exc:
            if exc.name != modname:
                raise
            continue  # that tool is not part of this build
        p = sub.add_parser(name, help=helptext)
        mod.add_parser(p)
    return parser


def main(argv=None):
    from .errors import UserError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args) or 0
    except UserError as e:
        print("trackpilot %s: %s" % (args.command, e), file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
