"""The simulated pilot's own SeaTalk1 codec (independent of firmware/trackpilot/devices/seatalk.py; checked
against the public vectors in shared/data/seatalk/seatalk_vectors.txt in the tests)."""

MODE_STANDBY = 0x00
MODE_AUTO = 0x02

KEY_AUTO = 0x01
KEY_STANDBY = 0x02
KEY_MINUS_1 = 0x05
KEY_MINUS_10 = 0x06
KEY_PLUS_1 = 0x07
KEY_PLUS_10 = 0x08
COURSE_KEYS = {KEY_MINUS_1: -1, KEY_MINUS_10: -10, KEY_PLUS_1: +1, KEY_PLUS_10: +10}
KEY_NAMES = {"auto": KEY_AUTO, "standby": KEY_STANDBY, "-1": KEY_MINUS_1, "-10": KEY_MINUS_10,
             "+1": KEY_PLUS_1, "+10": KEY_PLUS_10}


def popcount8(b):
    return bin(b & 0xFF).count("1")


def wire_bit9(byte, parity):
    """The 9th bit on the wire for a byte written with UART parity 'E', 'O' or 'N' (no parity:
    the stop bit, a mark, sits where the 9th bit is expected, so it reads as 1)."""
    if parity == "E":
        return popcount8(byte) & 1
    if parity == "O":
        return (popcount8(byte) & 1) ^ 1
    return 1


def parity_for(byte, command):
    """The UART parity that puts `command` (0/1) in the 9th bit (for the pilot's own sending)."""
    return "E" if (popcount8(byte) & 1) == (1 if command else 0) else "O"


def encode_heading(heading_deg, odd_rule="dotnet", turning_stbd=False):
    """Whole degrees -> (U nibble, VW low 6 bits) for 0x84/0x9C."""
    h = int(heading_deg) % 360
    u = h // 90
    rem = h % 90
    vw = rem // 2
    if rem & 1:
        u |= 0x4
    if turning_stbd and odd_rule == "dotnet":
        u |= 0x8
    return u, vw


def decode_heading(u, vw, odd_rule="dotnet"):
    h = (u & 3) * 90 + (vw & 0x3F) * 2
    if odd_rule == "dotnet":
        return h + (1 if u & 0x4 else 0)
    c = u & 0xC
    return h + (0 if not c else (2 if c == 0xC else 1))


def encode_84(heading_deg, course_deg, mode, alarms, rudder_deg, tt=0x08, odd_rule="dotnet",
              turning_stbd=False):
    u, vw = encode_heading(heading_deg, odd_rule, turning_stbd)
    c2 = int(round(course_deg * 2)) % 720
    vw |= (c2 // 180) << 6
    rr = int(round(max(-127, min(127, rudder_deg)))) & 0xFF
    return bytes((0x84, (u << 4) | 0x06, vw, c2 % 180, mode & 0xFF, alarms & 0xFF, rr, 0x00, tt))


def decode_84(d, odd_rule="dotnet"):
    u = d[1] >> 4
    return {"heading_deg": decode_heading(u, d[2], odd_rule),
            "course_deg": (d[2] >> 6) * 90 + d[3] / 2.0, "mode": d[4], "alarms": d[5],
            "rudder_deg": d[6] - 256 if d[6] > 127 else d[6], "turning_stbd": bool(u & 0x8)}


def encode_9c(heading_deg, rudder_deg, odd_rule="dotnet", turning_stbd=False):
    u, vw = encode_heading(heading_deg, odd_rule, turning_stbd)
    rr = int(round(max(-127, min(127, rudder_deg)))) & 0xFF
    return bytes((0x9C, (u << 4) | 0x01, vw, rr))


def encode_86(sender, key):
    return bytes((0x86, ((sender & 0x0F) << 4) | 0x01, key & 0xFF, (key ^ 0xFF) & 0xFF))


def decode_86(d):
    """-> (sender, key) or None if it is not a well-formed keystroke."""
    if len(d) != 4 or d[0] != 0x86 or (d[1] & 0x0F) != 1 or d[3] != (d[2] ^ 0xFF):
        return None
    return d[1] >> 4, d[2]


def datagram_len(attr):
    return 3 + (attr & 0x0F)
