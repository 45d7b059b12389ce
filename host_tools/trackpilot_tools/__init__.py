"""Host tools for trackpilot (CPython). The `trackpilot` command lives in cli.py."""
