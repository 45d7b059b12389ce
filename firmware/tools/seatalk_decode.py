# Decode a SeaTalk1 capture with the firmware's own framer and codec; one JSON object per datagram.
# Runs under MicroPython (and CPython). Used by `trackpilot seatalk decode`; see docs/SEATALK.md.
#
# Usage: micropython firmware/tools/seatalk_decode.py FILE [--format auto|bin|text]
#            [--odd-rule dotnet|knauf] [--gap-ms N] [--byte-ms N]
# bin:  plain 8-bit bytes as a UART receives them (no 9th bit): framed by seatalk.Framer. Bytes get
#       times byte_ms apart (default 0: untimed, so the idle-gap rule is off unless --gap-ms).
# text: the 9-bit text form (docs/SEATALK.md): `$STALK,...*hh` lines and/or per-byte lines like
#       `@1200 c84 86 26 97 02 00 00 00 08` (c = command bit set; @t_ms optional).
import sys

from trackpilot.devices import seatalk as st


def _jval(v):
    if v is None:
        return "null"
    if v is True:
        return "true"
    if v is False:
        return "false"
    if isinstance(v, int):
        return "%d" % v
    if isinstance(v, float):
        s = "%.6g" % v
        return s
    s = str(v)
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def emit(d, dg, t_ms):
    parts = []
    if t_ms is not None:
        parts.append('"t_ms": %d' % t_ms)
    parts.append('"bytes": "%s"' % " ".join("%02x" % b for b in dg))
    if "error" in d:
        parts.append('"error": ' + _jval(d["error"]))
    else:
        parts.append('"cmd": "%02x"' % d["cmd"])
        parts.append('"name": "%s"' % d["name"])
        for k in sorted(d.keys()):
            if k in ("cmd", "name"):
                continue
            v = d[k]
            if k == "mode":
                v = st.MODE_NAMES[v]
            parts.append('"%s": %s' % (k, _jval(v)))
    print("{" + ", ".join(parts) + "}")


def one(dg, t_ms, rule):
    try:
        emit(st.decode(dg, rule), dg, t_ms)
        return True
    except ValueError as e:
        emit({"error": str(e)}, dg, t_ms)
        return False


def is_text(data):
    for b in data[:4096]:
        if b < 9 or (13 < b < 32) or b > 126:
            return False
    return True


def decode_text(text, rule):
    n = bad = 0
    cur = bytearray()
    cur_t = None
    t = None

    def close():
        nonlocal n, bad, cur, cur_t
        if cur:
            if len(cur) < 2 or len(cur) != st.length_of(cur[1]):
                emit({"error": "incomplete datagram"}, cur, cur_t)
                bad += 1
            elif one(bytes(cur), cur_t, rule):
                n += 1
            else:
                bad += 1
        cur = bytearray()

    for lineno, line in enumerate(text.split("\n")):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if line.startswith("$"):
            close()
            try:
                dg = st.parse_stalk(line)
            except ValueError as e:
                print('{"line": %d, "error": %s}' % (lineno + 1, _jval(str(e))))
                bad += 1
                continue
            if one(dg, None, rule):
                n += 1
            else:
                bad += 1
            continue
        for tok in line.split():
            if tok[0] == "@":
                t = int(tok[1:])
                continue
            try:
                if len(tok) == 3 and tok[0] in "cC":  # `c84`; a 2-char token is data (c0 = 0xC0)
                    close()
                    cur.append(int(tok[1:], 16))
                    cur_t = t
                elif len(tok) == 2:
                    b = int(tok, 16)
                    if not cur:
                        print('{"line": %d, "error": "data byte %02x without a command byte"}' % (lineno + 1, b))
                        bad += 1
                        continue
                    cur.append(b)
                else:
                    raise ValueError(tok)
            except ValueError:
                print('{"line": %d, "error": %s}' % (lineno + 1, _jval("bad token " + tok)))
                bad += 1
                continue
            if len(cur) >= 2 and len(cur) == st.length_of(cur[1]):
                close()
    close()
    return n, bad


def decode_bin(f, rule, gap_ms, byte_ms):
    fr = st.Framer(gap_ms=gap_ms)
    n = 0
    t = 0
    while True:
        chunk = f.read(256)
        if not chunk:
            break
        for b in chunk:
            fr.feed(b, t)
            t += byte_ms
            while fr.pending():
                tt = fr.pop_t()
                dg = fr.pop()
                one(dg, tt if byte_ms else None, rule)
                n += 1
    sys.stderr.write("seatalk: %d datagrams framed (%d unknown types), %d bytes skipped, %d partials ended by a gap\n"
                     % (fr.datagrams, fr.unknown, fr.dropped_bytes, fr.dropped_gap))
    return n


def main(argv):
    if len(argv) < 2:
        sys.stderr.write("usage: seatalk_decode.py FILE [--format auto|bin|text] [--odd-rule dotnet|knauf] [--gap-ms N] [--byte-ms N]\n")
        sys.exit(2)
    path = argv[1]
    fmt = "auto"
    rule = st.ODD_DOTNET
    gap_ms = 0
    byte_ms = 0
    i = 2
    while i < len(argv):
        a = argv[i]
        v = argv[i + 1] if i + 1 < len(argv) else None
        if v is None:
            sys.stderr.write("missing value for %s\n" % a)
            sys.exit(2)
        if a == "--format":
            fmt = v
        elif a == "--odd-rule":
            rule = st.ODD_KNAUF if v == "knauf" else st.ODD_DOTNET
        elif a == "--gap-ms":
            gap_ms = int(v)
        elif a == "--byte-ms":
            byte_ms = int(v)
        else:
            sys.stderr.write("unknown option %s\n" % a)
            sys.exit(2)
        i += 2
    with open(path, "rb") as f:
        head = f.read(4096)
    if fmt == "auto":
        fmt = "text" if head and is_text(head) else "bin"
    if fmt == "text":
        with open(path, "rb") as f:
            n, bad = decode_text(f.read().decode(), rule)
        sys.stderr.write("seatalk: %d datagrams decoded, %d errors\n" % (n, bad))
    else:
        with open(path, "rb") as f:
            decode_bin(f, rule, gap_ms, byte_ms)


main(sys.argv)
