"""Output folders that are whole or plainly marked partial.

A run writes into a fresh hidden folder beside the requested one (`.NAME.tmp-PID`); only when it
has finished is that folder renamed to NAME, replacing an older output in one step. An interrupted
run (Ctrl-C, a crash) leaves the older complete output untouched and its own files in
`NAME.partial/` with a PARTIAL.txt saying why, so the two are never mixed.
"""
import os
import shutil
from contextlib import contextmanager
from pathlib import Path

PARTIAL_NOTE = "PARTIAL.txt"


def _remove(path):
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


@contextmanager
def fresh_output(final):
    """`with fresh_output("sim_out") as tmp:` write everything into tmp (a Path). On normal exit
    tmp becomes `final`; on any exception it becomes `final.partial` (with PARTIAL.txt) and the
    exception goes on."""
    final = Path(final).absolute()  # the firmware process runs in another working directory
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.parent / (".%s.tmp-%d" % (final.name, os.getpid()))
    _remove(tmp)
    tmp.mkdir()
    try:
        yield tmp
    except BaseException as exc:
        partial = final.parent / (final.name + ".partial")
        _remove(partial)
        reason = "interrupted (Ctrl-C)" if isinstance(exc, KeyboardInterrupt) else "stopped by an error: %r" % exc
        (tmp / PARTIAL_NOTE).write_text(
            "This output is PARTIAL: the run was %s before it finished.\n"
            "The last complete output, if any, is still in %s/.\n" % (reason, final.name))
        os.replace(tmp, partial)
        raise
    old = None
    if final.exists() or final.is_symlink():
        old = final.parent / (".%s.old-%d" % (final.name, os.getpid()))
        _remove(old)
        os.replace(final, old)
    os.replace(tmp, final)
    if old is not None:
        _remove(old)
    stale = final.parent / (final.name + ".partial")
    if stale.is_dir() and (stale / PARTIAL_NOTE).exists():
        shutil.rmtree(stale)  # superseded by this complete run
