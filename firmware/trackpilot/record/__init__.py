"""The flight recorder: the binary log format and the logger that writes it."""
