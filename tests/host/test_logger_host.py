"""Logger on CPython with a tmp directory: power loss loses at most ~1 s, parts are bounded,
old sessions go first (never the current one), a full flash degrades as documented, ENOSPC and
failing writes never raise."""
import errno
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "firmware"))

from trackpilot.record import logfmt as L  # noqa: E402
from trackpilot.record.logger import Logger, parse_name  # noqa: E402

from logseq import sailing_records, track_waypoints, write_log  # noqa: E402


def _decode_dir(root):
    out = []
    for p in sorted(Path(root).iterdir()):
        out += [(p.name, r) for r in L.iter_records(p.read_bytes())]
    return out


def _used(root):
    return sum(p.stat().st_size for p in Path(root).iterdir())


def test_power_loss_loses_at_most_one_second(tmp_path):
    lg = Logger(str(tmp_path), fw_version="t")
    t0 = (1 << 30) - 5000  # crosses the tick wrap
    lg.start(t0, reset_cause="brownout")
    last_logged = None
    for k, (r, _) in enumerate(sailing_records(400, t0_ms=t0)):
        lg.control(r)
        last_logged = r.t_ms
        lg.tick(r.t_ms)
        if k in (7, 58, 199, 399):  # the power goes: read what is on flash, never closed
            recs = [x for _, x in _decode_dir(tmp_path)]
            ctl = [x for x in recs if x.type == "control"]
            assert not [x for x in recs if x.type == "damage"]
            assert recs[0].type == "header" and recs[0].get("reset") == "brownout"
            lost_ms = L.t_span_ms(ctl[-1].t_ms, last_logged) if ctl else 10**6
            assert lost_ms <= 1000 + 10, "lost %d ms at record %d" % (lost_ms, k)
    lg.close()


def test_rotation_is_bounded_and_every_part_decodes(tmp_path):
    lg = write_log(str(tmp_path), 6000, max_file_bytes=16 * 1024)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert len(names) >= 10
    assert [parse_name(n) for n in names] == [(1, i) for i in range(len(names))]
    for p in tmp_path.iterdir():
        assert p.stat().st_size <= 16 * 1024
        recs = list(L.iter_records(p.read_bytes()))
        assert recs[0].type == "header" and recs[1].type == "track"  # each part stands alone
        assert len(recs[1].waypoints) == len(track_waypoints())
        assert next(r for r in recs if r.type == "control").key
        assert not [r for r in recs if r.type == "damage"]
    ctl = [r for _, r in _decode_dir(tmp_path) if r.type == "control"]
    assert len(ctl) == 6000 and lg.dropped_control == 0
    exp = [r.lat_e7 for r, _ in sailing_records(6000, t0_ms=(1 << 30) - 60000)]
    assert [r.lat_e7 for r in ctl] == exp


def _old_session(root, s, nbytes):
    with open(os.path.join(root, "%04d-00.tpl" % s), "wb") as f:
        f.write(b"\x55" * nbytes)


def test_low_space_deletes_oldest_sessions_first_never_current(tmp_path):
    root = str(tmp_path)
    for s in (3, 4, 5):
        _old_session(root, s, 30000)
    quota = 200000
    seen = []

    def free():
        names = sorted(os.listdir(root))
        seen.append([n for n in names if not n.startswith("0006")])
        return quota - _used(root)

    lg = Logger(root, free_fn=free, max_file_bytes=20000, low_water_bytes=60000,
                control_reserve_bytes=30000, event_reserve_bytes=4000, space_check_ms=1000)
    lg.start(0)
    assert lg.session == 6
    for r, events in sailing_records(12000, t0_ms=0):
        lg.control(r)
        for kind, text in events:
            lg.event(kind, text, r.t_ms)
        lg.tick(r.t_ms)
    lg.close()
    # Old sessions went oldest first: every listing seen is a suffix of the original one.
    orig = ["0003-00.tpl", "0004-00.tpl", "0005-00.tpl"]
    for names in seen:
        assert names == orig[len(orig) - len(names):]
    assert lg.deleted_files == 3
    left = sorted(os.listdir(root))
    assert left and all(n.startswith("0006-") for n in left)
    assert _used(root) <= quota
    # Then control records were dropped, events kept a while longer, and it was all logged.
    assert lg.dropped_control > 0
    recs = [r for _, r in _decode_dir(root)]
    texts = [r.text for r in recs if r.type == "event"]
    assert any(t.startswith("flash low") for t in texts)
    last_ctl = max(i for i, r in enumerate(recs) if r.type == "control")
    assert any(r.type == "event" and r.kind == "KEY" for r in recs[last_ctl + 1:])
    assert not [r for r in recs if r.type == "damage"]


class _QuotaFile:
    """A file on a flash that raises ENOSPC past a quota (after writing what fits)."""

    def __init__(self, path, mode, state):
        self.f = open(path, mode)
        self.state = state

    def write(self, data):
        room = self.state["quota"] - self.state["used"]
        if len(data) > room:
            if room > 0 and self.state["partial"]:
                self.f.write(bytes(data[:room]))
                self.state["used"] += room
            raise OSError(errno.ENOSPC, "No space left on device")
        self.state["used"] += len(data)
        return self.f.write(data)

    def flush(self):
        self.f.flush()

    def close(self):
        self.f.close()


def test_enospc_on_write_never_raises_and_recovers(tmp_path):
    for partial in (False, True):
        root = tmp_path / ("p%d" % partial)
        state = {"quota": 30000, "used": 0, "partial": partial}
        lg = Logger(str(root), open_fn=lambda p, m: _QuotaFile(p, m, state),
                    free_fn=lambda: 10**9, max_file_bytes=8000)  # statvfs that lies
        lg.start(0)
        lg.track(track_waypoints(), "x")
        n = 0
        for r, events in sailing_records(3000, t0_ms=0):
            if n == 2000:
                state["quota"] += 200000  # someone pulled and deleted logs: space is back
            lg.control(r)
            lg.event("INFO", "record %d" % n, r.t_ms)
            lg.tick(r.t_ms)
            n += 1
        lg.close()
        assert lg.write_errors > 0 and lg.dropped_control > 0
        files = list(root.iterdir())
        assert len(files) < 40, "no file storm while full: %d files" % len(files)
        for p in files:
            assert next(L.iter_records(p.read_bytes())).type == "header"
        recs = [r for _, r in _decode_dir(root)]
        dmg = [r for r in recs if r.type == "damage"]
        assert all(d.reason == "truncated" for d in dmg) and (bool(dmg) == partial)
        ctl = [r for r in recs if r.type == "control"]
        exp = {r.t_ms: r.lat_e7 for r, _ in sailing_records(3000, t0_ms=0)}
        assert all(exp[r.t_ms] == r.lat_e7 for r in ctl)  # what was saved is exact
        assert L.t_span_ms(ctl[-1].t_ms, max(exp)) <= 1200, "logging resumed"


def test_unwritable_root_does_not_raise(tmp_path):
    blocker = tmp_path / "notadir"
    blocker.write_bytes(b"x")
    lg = Logger(str(blocker / "log"))
    assert lg.start(0) == ""
    for r, _ in sailing_records(20, t0_ms=0):
        lg.control(r)
        lg.event("INFO", "x", r.t_ms)
        lg.tick(r.t_ms)
    lg.close()
    assert lg.write_errors > 0 and lg.dropped_control == 20


class _SmallFs:
    """statvfs of a small filesystem holding only the log directory: 4 KiB blocks."""

    def __init__(self, root, total_bytes):
        self.root = root
        self.blocks = total_bytes // 4096

    def __call__(self, path):
        used = sum((p.stat().st_size + 4095) // 4096 for p in Path(self.root).iterdir())
        free = self.blocks - used
        return (4096, 4096, self.blocks, free, free, 0, 0, 0, 0, 255)


def test_retention_budget_on_a_small_filesystem_keeps_older_sessions_at_boot(tmp_path):
    """Issue 14.12: with the config's defaults a new part needed 1.25 MiB free, so the first boot
    on a small filesystem deleted every older session. On a 1 MiB filesystem with three older
    sessions (840 KB) nothing is deleted at boot; logging then deletes oldest first, never the
    current session, and the logs never overrun the filesystem."""
    sys.path.insert(0, str(ROOT / "firmware"))
    from trackpilot import config

    log_cfg = config.defaults()["log"]
    root = str(tmp_path)
    for s in (3, 4, 5):
        _old_session(root, s, 280000)
    fs = _SmallFs(root, 1024 * 1024)
    lg = Logger(root, statvfs=fs, max_file_bytes=log_cfg["max_file_bytes"],
                min_free_bytes=log_cfg["min_free_bytes"], space_check_ms=1000)
    lg.start(0)
    assert lg.session == 6
    assert lg.deleted_files == 0, sorted(os.listdir(root))
    assert lg.low_water_bytes == 128 * 1024  # 1/8 of the filesystem, below the configured 256 KiB
    pad = "x" * 180
    n = 0
    for r, events in sailing_records(6000, t0_ms=0):
        lg.control(r)
        lg.event("INFO", pad, r.t_ms)
        lg.tick(r.t_ms)
        n += 1
        if lg.deleted_files:
            break
    lg.close()
    left = sorted(os.listdir(root))
    assert lg.deleted_files == 1 and left[0].startswith("0004-"), left  # the oldest went first
    assert any(x.startswith("0006-") for x in left)
    assert _used(root) <= 1024 * 1024
    # the free space above the reserve (196 KiB free - 128 KiB) was used before any deletion
    assert lg.bytes_written > 60000, (n, lg.bytes_written)


def test_log_format_doc_states_the_config_defaults():
    """Issue 14.12: docs/LOG_FORMAT.md and the config's defaults said different things."""
    from trackpilot import config

    doc = (ROOT / "docs" / "LOG_FORMAT.md").read_text()
    log_cfg = config.defaults()["log"]
    assert "`log.max_file_bytes` (default %d KiB)" % (log_cfg["max_file_bytes"] // 1024) in doc
    assert "`log.min_free_bytes` (default %d KiB)" % (log_cfg["min_free_bytes"] // 1024) in doc
    assert Logger.max_file_bytes == log_cfg["max_file_bytes"]
    assert Logger.low_water_bytes == log_cfg["min_free_bytes"]
