# SeaTalk1 codec, parity rule and 8-bit framer, against tests/data/seatalk/seatalk_vectors.txt.
import tpassert as T
from trackpilot.devices import seatalk as st

VECTORS = "tests/data/seatalk/seatalk_vectors.txt"


def h(s):
    return bytes(int(x, 16) for x in s.split())


def _runs(line):
    # runs of >= 3 two-digit hex tokens; '|' and ';' end a run (the file's column separators)
    out = []
    cur = []
    for tok in line.replace("|", " | ").replace(";", " ; ").split():
        if len(tok) == 2 and all(c in "0123456789abcdefABCDEF" for c in tok):
            cur.append(int(tok, 16))
            continue
        if len(cur) >= 3:
            out.append(bytes(cur))
        cur = []
    if len(cur) >= 3:
        out.append(bytes(cur))
    return out


def _file_datagrams():
    dgs = []
    stalk = []
    with open(VECTORS) as f:
        for line in f:
            line = line.strip()
            if line.startswith("# $STALK"):
                stalk.append(line[2:].split()[0])
            elif line and not line.startswith("#"):
                dgs.extend(_runs(line))
    return dgs, stalk


# (bytes, expected fields) as the sources assert them (see the file's third column)
EXPECT = [
    ("9c 01 12 00", {"name": "heading_rudder", "heading_deg": 36, "rudder_deg": 0}),
    ("84 06 12 00 00 00 00 00 08", {"heading_deg": 36, "mode": st.MODE_STANDBY, "pilot_type": 8,
                                    "course_deg": 0}),
    ("86 01 02 fd", {"sender": 0, "key": st.KEY_STANDBY, "key_name": "standby"}),
    ("95 86 26 97 02 00 00 00 08", {"name": "ap_status_setting", "heading_deg": 76,
                                    "course_deg": 75.5, "mode": st.MODE_AUTO}),
    ("10 01 00 01", {"angle_deg": 0.5}),
    ("85 06 00 00 C0 0D 17 00 E8", {"name": "nav_to_waypoint", "xte_nm": 0, "bearing_deg": 0,
                                    "dist_nm": 2.2}),
    ("11 01 12 04", {"speed_kn_x10": 184}),
    ("86 11 06 f9", {"sender": 1, "key": st.KEY_MINUS_10}),
    ("86 11 08 f7", {"sender": 1, "key": st.KEY_PLUS_10}),
    ("9c 01 03 0f", {"heading_deg": 6, "rudder_deg": 15}),
    ("84 86 26 97 02 00 00 00 08", {"heading_deg": 76, "turning_stbd": True, "course_deg": 75.5,
                                    "mode": st.MODE_AUTO}),
    ("95 86 0E 00 10 00 00 04 08", {"mode": st.MODE_CAL, "mode_raw": 0x10, "display": 4}),
    ("85 06 00 00 C0 0D 1F 00 E0", {"xte_large": True, "dist_nm": 2.2}),
    ("86 21 05 fa", {"sender": 2, "key_name": "-1"}),
    ("86 21 06 f9", {"key_name": "-10"}),
    ("86 21 07 f8", {"key_name": "+1"}),
    ("86 21 08 f7", {"key_name": "+10"}),
    ("86 21 01 fe", {"key_name": "auto"}),
    ("86 21 02 fd", {"key_name": "standby"}),
    ("10 01 01 66", {"angle_deg": 179}),
    ("11 01 12 03", {"speed_kn_x10": 183}),
    ("99 00 e4", {"variation_deg": -28}),
    ("86 01 63 9c", {"sender": 0, "key": 0x63}),
]


def test_vectors_decode():
    n = 0
    for hexs, want in EXPECT:
        d = st.decode(h(hexs))
        for k in want:
            v = d[k]
            if isinstance(want[k], float) or isinstance(v, float):
                T.near(v, want[k], 1e-4, hexs + " " + k)
            else:
                T.eq(v, want[k], hexs + " " + k)
            n += 1
    T.eq(n, 47, "fields checked")


def test_every_file_datagram_is_in_the_table_and_frames():
    dgs, stalk = _file_datagrams()
    T.eq(len(dgs), 29, "datagrams in the file")
    known = set(h(x) for x, _ in EXPECT)
    fr = st.Framer(gap_ms=0)
    for dg in dgs:
        T.true(st.plausible(dg), "plausible " + dg.hex())
        st.decode(dg)  # must not raise
        if dg[0] in (0x84, 0x85, 0x86, 0x95, 0x9C, 0x10, 0x11, 0x99):
            T.true(dg in known, "vector without an expectation: " + dg.hex())
    # the whole file back to back as one 8-bit stream: every datagram comes out, in order
    got = []
    for dg in dgs:
        for b in dg:
            fr.feed(b, 0)
            while fr.pending():
                got.append(fr.pop())
    T.eq(got, dgs)
    T.eq(len(stalk), 2)


def test_signalk_bug_vectors_follow_the_documented_rules():
    a = st.parse_stalk("$STALK,84,B6,10,00,00,00,00,00,00*14")
    b = st.parse_stalk("$STALK,9C,51,1E,00*4B")
    T.eq(st.decode(a)["heading_deg"], 302)  # dotnet rule (SignalK's test expects 304: its bug)
    T.eq(st.decode(b)["heading_deg"], 151)  # SignalK expects 152
    T.eq(st.decode(a, st.ODD_KNAUF)["heading_deg"], 303)  # Knauf: bits set in U & 0xC
    T.eq(st.decode(b, st.ODD_KNAUF)["heading_deg"], 151)
    T.eq(st.to_stalk(a), "$STALK,84,B6,10,00,00,00,00,00,00*14")
    T.raises(ValueError, st.parse_stalk, "$STALK,9C,51,1E,00*4C")


def test_parity_vectors():
    for hexs, want in (("86 11 08 f7", "EEOO"), ("9c 01 03 0f", "OOEE"), ("86 11 06 f9", "EEEE")):
        dg = h(hexs)
        got = "".join(st.parity_for(b, i == 0) for i, b in enumerate(dg))
        T.eq(got, want, hexs)
        for i, b in enumerate(dg):
            T.eq(st.command_bit(b, got[i]), 1 if i == 0 else 0)
    for b in range(256):
        for c in (0, 1):
            T.eq(st.command_bit(b, st.parity_for(b, c)), c)
    T.raises(ValueError, st.command_bit, 0x84, "N")


def test_encoders_round_trip():
    for rule in (st.ODD_DOTNET, st.ODD_KNAUF):
        for hd in range(360):
            for turn in (False, True):
                course = (hd * 7 % 720) / 2
                dg = st.encode_84(hd, course, st.MODE_AUTO, -5, turn, odd_rule=rule)
                d = st.decode(dg, rule)
                T.eq(d["heading_deg"], hd, "84 %d %r" % (hd, turn))
                T.eq(d["course_deg"], course)
                T.eq(d["turning_stbd"], turn)
                T.eq(d["rudder_deg"], -5)
                d = st.decode(st.encode_9c(hd, 12, turn, rule), rule)
                T.eq(d["heading_deg"], hd)
                T.eq(d["turning_stbd"], turn)
        T.eq(st.decode(st.encode_89(hd))["heading_deg"], hd)
    T.eq(st.encode_84(76, 75.5, st.MODE_AUTO, 0, True), h("84 86 26 97 02 00 00 00 08"))
    T.eq(st.encode_84(76, 75.5, st.MODE_AUTO, 0, True, cmd=0x95), h("95 86 26 97 02 00 00 00 08"))
    T.eq(st.encode_84(36, 0), h("84 06 12 00 00 00 00 00 08"))
    T.eq(st.encode_9c(36), h("9c 01 12 00"))
    T.eq(st.encode_9c(6, 15), h("9c 01 03 0f"))
    T.eq(st.encode_86(st.KEY_PLUS_10, 1), h("86 11 08 f7"))
    T.eq(st.encode_86(st.KEY_STANDBY, 0), h("86 01 02 fd"))
    T.eq(st.encode_10(0.5), h("10 01 00 01"))
    T.eq(st.encode_10(179), h("10 01 01 66"))
    T.eq(st.encode_11(18.4), h("11 01 12 04"))
    T.eq(st.encode_11(18.3), h("11 01 12 03"))
    T.eq(st.encode_99(-28), h("99 00 e4"))
    T.eq(st.encode_85(0.0, 0.0, False, 2.2), h("85 06 00 00 C0 0D 17 00 E8"))
    d = st.decode(st.encode_85(-0.37, 271.5, True, 12.3))
    T.near(d["xte_nm"], -0.37, 1e-6)
    T.near(d["bearing_deg"], 271.5, 1e-6)
    T.near(d["dist_nm"], 12.3, 1e-5)
    T.eq(d["xte_large"], True)
    T.eq(d["bearing_true"], True)


def test_bad_input_is_a_clear_error():
    T.raises(ValueError, st.decode, h("84 06 12"))
    T.raises(ValueError, st.decode, h("86 11 08 f8"))
    T.raises(ValueError, st.encode_84, 10, 10, 9)
    T.raises(ValueError, st.encode_9c, 10, 200)
    T.raises(ValueError, st.encode_11, 200)
    T.raises(ValueError, st.encode_86, 300)
    T.eq(st.decode(h("a8 53 80 00 00 d3"))["name"], "not_decoded")


def _frame_all(fr, data, t0=0, dt=0):
    out = []
    t = t0
    for b in data:
        fr.feed(b, t)
        t += dt
        while fr.pending():
            out.append(fr.pop())
    return out


def test_framer_resyncs_after_garbage_and_cut_datagrams():
    a = h("84 86 26 97 02 00 00 00 08")
    k = h("86 11 08 f7")
    c = h("9c 01 12 00")
    # garbage that looks like starts of known types, a cut 0x84, then good datagrams
    junk = h("84 33 86 11 08 00 9c") + a[:5]
    fr = st.Framer(gap_ms=0)
    got = _frame_all(fr, junk + k + c + a + k)
    T.eq(got[-4:], [k, c, a, k])
    T.true(fr.dropped_bytes > 0)
    # the same cut datagram separated by an idle gap: the partial is dropped at once
    fr = st.Framer(gap_ms=5)
    out = _frame_all(fr, a[:4], 0, 2)
    out += _frame_all(fr, k + c, 100, 2)
    T.eq(out, [k, c])
    T.eq(fr.dropped_gap, 1)


def test_framer_unknown_types_and_queue_bound():
    fr = st.Framer(gap_ms=0, depth=2)
    unk = h("a1 03 11 22 33 44")
    k = h("86 11 08 f7")
    for b in unk + k + k + k:
        fr.feed(b, 0)
    T.eq(fr.pending(), 2)
    T.eq(fr.queue_overflow, 2)
    T.eq(fr.unknown, 1)
    T.eq(fr.pop(), k)
    fr = st.Framer(gap_ms=0, accept_unknown=False)
    T.eq(_frame_all(fr, unk + k), [k])


def test_framer_handles_tick_wrap():
    a = h("9c 01 12 00")
    fr = st.Framer(gap_ms=5)
    t = (1 << 30) - 4
    out = []
    for b in a:
        fr.feed(b, t)
        t = (t + 2) & ((1 << 30) - 1)
    T.eq(fr.pop(), a)


def test_framer_feed_does_not_allocate():
    import micropython

    parts = [h("84 86 26 97 02 00 00 00 08"), h("86 11 08 f7"), h("33 9c 01"), h("a1 03 11 22 33 44")]
    fr = st.Framer(gap_ms=5, depth=4)
    t = 0
    n = 0
    micropython.heap_lock()  # any allocation inside raises MemoryError
    try:
        for _ in range(50):
            for p in parts:
                t += 10  # an idle gap before each datagram
                for b in p:
                    fr.feed(b, t)
                    t += 2
                while fr.pending():
                    fr._qn -= 1  # consume without pop() (which makes a bytes object)
                    fr._qhead = (fr._qhead + 1) % 4
                    n += 1
    finally:
        micropython.heap_unlock()
    T.eq(n, 150)  # 0x84, 0x86 and the unknown 0xA1 each time; the cut "33 9c 01" ends at a gap
    T.eq(fr.dropped_gap, 50)
