"""The unix-port board on a pseudo-terminal lives in the package (trackpilot board-sim uses it too)."""
from trackpilot_tools.ptyboard import ROOT, PtyBoard  # noqa: F401
