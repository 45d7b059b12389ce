"""Log format on CPython: size budget on a realistic sailing sequence, cuts at every byte offset,
random corruption, deleted spans: the decoder recovers every intact record and reports damage."""
import random
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "firmware"))

from trackpilot.record import logfmt as L  # noqa: E402
from trackpilot_tools.logdecode import CONTROL_COLUMNS, decode_files  # noqa: E402

from logseq import sailing_records, track_waypoints, write_log  # noqa: E402

BUDGET_B_PER_RECORD = 33


def _content(r):
    if r.type == "control":
        return ("control", r.key) + tuple(getattr(r, c) for c in CONTROL_COLUMNS)
    if r.type == "event":
        return ("event", r.t_ms, r.kind, r.text)
    if r.type == "header":
        return ("header", tuple(sorted(r.info.items())), r.fields)
    if r.type == "track":
        return ("track", r.track_id, tuple((w.lat_e7, w.lon_e7, w.name) for w in r.waypoints))
    return ("damage", r.reason)


def _build(n, key_every=25, seed=2):
    """A log with its frames: [(start, end, type, is_key)] and the clean decoded records."""
    enc = L.LogEncoder(key_every=key_every)
    out = bytearray()
    frames = []

    def add(b, typ, key=False):
        frames.append((len(out), len(out) + len(b), typ, key))
        out.extend(b)

    add(enc.header(fw_version="t", track_id="x", reset_cause="power_on"), "header")
    add(enc.encode_track(track_waypoints(), "x"), "track")
    for r, events in sailing_records(n, seed=seed):
        b = bytes(enc.encode_control(r))
        add(b, "control", b[0] == 0xB0 | L.T_KEY)
        for kind, text in events:
            add(bytes(enc.encode_event(kind, text, r.t_ms)), "event")
    data = bytes(out)
    clean = list(L.iter_records(data))
    assert [r.type for r in clean] == [f[2] for f in frames]
    return data, frames, clean


def _expected(frames, clean, damaged, garbage_at=-1, aligned=False):
    """Records the decoder must recover when the frames with `damaged(start, end)` true are
    hit (and garbage was inserted before the frame at `garbage_at`): intact frames, and control
    deltas whose chain back to an intact keyframe is intact. `aligned`: whole frames vanished
    (no bad bytes), so only a lost control record breaks the chain (by its sequence number)."""
    exp = []
    orphans = 0
    chain = False
    for (s, e, typ, key), rec in zip(frames, clean):
        if s == garbage_at:
            chain = False
        if damaged(s, e):
            if typ == "control" or not aligned:
                chain = False
            continue
        if typ == "header":
            chain = False
        if typ == "control":
            if key:
                chain = True
            elif not chain:
                orphans += 1
                continue
        exp.append(_content(rec))
    return exp, orphans


def test_bytes_per_record_on_a_realistic_hour(tmp_path):
    n = 18000  # one hour at 5 Hz
    enc = L.LogEncoder(key_every=25)
    total = 0
    for r, _ in sailing_records(n, seed=7):
        total += len(enc.encode_control(r))
    per_record = total / n
    # The whole file as the logger writes it: header, track, events, keyframes, rotation.
    lg = write_log(str(tmp_path), n, seed=7)
    files = sorted(tmp_path.iterdir())
    file_bytes = sum(f.stat().st_size for f in files)
    d = decode_files(files)
    print("\ncontrol records: %.2f B/record (%d keyframes), %d B/h of control records;"
          " files incl. %d events, headers, track: %d B/h in %d files; 10 h = %.2f MB"
          % (per_record, enc.keyframes, total, len(d.events), file_bytes, len(files),
             file_bytes * 10 / 1e6))
    assert per_record <= BUDGET_B_PER_RECORD
    assert file_bytes * 10 <= 6_000_000
    assert len(d.controls) == n and not d.damage
    assert lg.bytes_written == file_bytes


def test_cut_at_every_byte_offset():
    data, frames, clean = _build(60, key_every=10)
    ends = {0}
    for s, e, _t, _k in frames:
        ends.add(e)
    for cut in range(len(data) + 1):
        got = list(L.iter_records(data[:cut]))
        recs = [_content(r) for r in got if r.type != "damage"]
        exp, orphans = _expected(frames, clean, lambda s, e: e > cut)
        assert recs == exp, "cut at %d" % cut
        dmg = [r for r in got if r.type == "damage"]
        last_end = max(x for x in ends if x <= cut)
        if cut in ends:
            assert not dmg, "cut at a frame boundary %d" % cut
        else:
            assert sum(x.length for x in dmg) == cut - last_end, "cut at %d" % cut
            assert dmg[-1].reason in ("truncated", "bad frame")


def test_random_corruption_recovers_every_intact_record():
    data, frames, clean = _build(400, key_every=25, seed=3)
    rnd = random.Random(99)
    for trial in range(150):
        bad = bytearray(data)
        hit = set()
        for _ in range(rnd.randint(1, 6)):
            if rnd.random() < 0.7:  # flip bits in one byte
                p = rnd.randrange(len(bad))
                bad[p] ^= rnd.randint(1, 255)
                hit.add(p)
            else:  # a burst of garbage
                p = rnd.randrange(len(bad) - 40)
                for q in range(p, p + rnd.randint(2, 40)):
                    old = bad[q]
                    bad[q] = rnd.randrange(256)
                    if bad[q] != old:
                        hit.add(q)
        got = list(L.iter_records(bytes(bad)))
        recs = [_content(r) for r in got if r.type != "damage"]
        exp, orphans = _expected(frames, clean, lambda s, e: any(s <= p < e for p in hit))
        assert recs == exp, "trial %d" % trial
        dmg = [r for r in got if r.type == "damage"]
        spans = [(x.offset, x.offset + x.length) for x in dmg if x.reason != "no keyframe"]
        for p in hit:  # every damaged byte is inside a reported damage span
            assert any(a <= p < b for a, b in spans), "trial %d byte %d" % (trial, p)
        assert sum(x.records for x in dmg) == orphans


def test_deleted_and_inserted_spans():
    data, frames, clean = _build(300, key_every=25, seed=4)
    rnd = random.Random(5)
    for trial in range(90):
        a = rnd.randrange(len(data) - 200)
        b = a + rnd.randint(1, 200)
        if trial % 3 == 2:  # lose whole frames exactly: only the sequence number shows it
            a = rnd.choice(frames[5:-20])[0]
            b = rnd.choice([f for f in frames if f[0] > a][:10])[0]
        if trial % 3:
            mangled = data[:a] + data[b:]  # lost bytes (e.g. a flash page)
            aligned = trial % 3 == 2
            exp, orphans = _expected(frames, clean, lambda s, e: s < b and e > a,
                                     -1 if aligned else b, aligned)
        else:
            mangled = data[:a] + bytes(rnd.randrange(256) for _ in range(b - a)) + data[a:]
            exp, orphans = _expected(frames, clean, lambda s, e: s < a < e,
                                     min(f[0] for f in frames if f[0] >= a))
        got = list(L.iter_records(mangled))
        recs = [_content(r) for r in got if r.type != "damage"]
        assert recs == exp, "trial %d" % trial
        lost_control = any(f[2] == "control" and a <= f[0] < b for f in frames)
        if not (trial % 3 == 2 and not lost_control):  # only events vanished whole: undetectable
            assert any(r.type == "damage" for r in got), "trial %d" % trial
        assert sum(x.records for x in got if x.type == "damage") == orphans


def test_concatenated_sessions_decode_with_their_own_headers():
    d1, _, c1 = _build(30, key_every=10, seed=1)
    d2, _, c2 = _build(30, key_every=7, seed=2)
    got = [_content(r) for r in L.iter_records(d1 + d2)]
    assert got == [_content(r) for r in c1 + c2]
