"""Mistakes a user can fix (a missing file, a bad option value): the CLI prints the message as one
line, `trackpilot COMMAND: message`, and exits 2; no traceback."""


class UserError(Exception):
    """Raised by a command for an ordinary mistake; the text says what is wrong and how to fix it."""


def script_error_line(exc):
    """The last non-empty line of a failed MicroPython script's output (its own error message)."""
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    line = lines[-1] if lines else str(exc)
    kind, sep, rest = line.partition(": ")
    if sep and kind.endswith(("Error", "Exception")) and kind.replace(".", "").isalnum():
        return rest  # "ValueError: no sample 'x'" -> "no sample 'x'": the text is for a person
    return line


def check_port(option, value):
    """A TCP/UDP port given on the command line: 1..65535, else a UserError naming the option."""
    if not 0 < value < 65536:
        raise UserError("%s %d: a port is 1..65535" % (option, value))
