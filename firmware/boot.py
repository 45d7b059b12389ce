# boot.py: runs before main.py. Nothing here may engage anything; it only prepares storage.
try:
    import os

    for d in ("/log", "/tracks"):
        try:
            os.mkdir(d)
        except OSError:
            pass
except Exception:  # boot must never stop the REPL from coming up
    pass
