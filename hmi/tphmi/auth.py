"""Authenticated HMI commands over the network: HMAC-SHA256 with a per-boat key and a counter.

Packet (27 bytes, little endian):
    b"TPC\\x01"  boat_id u16  counter u32  command u8  tag[16]
    tag = HMAC-SHA256(key, first 11 bytes)[:16]
Commands: ENGAGE 1, STANDBY 2, NEXT_WP 3, PREV_WP 4, ACK 5, TRIAL 6 (the same names the buttons give).

Counters survive reboots of either side (state files written to a temporary name, then renamed):
- the sender (remote box) reserves counters in blocks: it persists "next free = n + block" before
  using any of n..n+block-1, so after a crash it starts at the persisted value and never reuses one;
- the verifier (boat) persists the last accepted counter before the command is acted on, and
  refuses any counter <= it, also after its own reboot.
Both state records carry the key's fingerprint; a record for another key is refused (re-provision).
A missing or corrupt state file is reported and every command refused: no silent reset to 0.

Usage:
    key = open("/hmi.key", "rb").read()                        # 32 random bytes, per boat
    v = CommandVerifier(key, boat_id=7, store=FileStore("/auth_rx.bin"))
    cmd, why = v.verify(packet)       # ("ENGAGE", "") or (None, "replay: counter 5 <= 9")
    s = CommandSigner(key, boat_id=7, store=FileStore("/auth_tx.bin"))
    packet = s.sign("STANDBY")
    init_state(FileStore("/auth_rx.bin"), key, 0)               # provisioning (docs/HMI.md)
"""
import struct

try:
    import hashlib
except ImportError:  # some builds lack it; everything else in tphmi works without
    hashlib = None

from trackpilot.compat import const

CMD_CODES = (("ENGAGE", 1), ("STANDBY", 2), ("NEXT_WP", 3), ("PREV_WP", 4), ("ACK", 5), ("TRIAL", 6))
CMD_MAGIC = b"TPC\x01"
TAG_LEN = const(16)
BODY_LEN = const(11)  # magic 4 + boat_id 2 + counter 4 + command 1
PKT_LEN = const(27)
_STATE_MAGIC = b"TPK\x01"
_STATE_LEN = const(16)  # magic 4 + counter u32 + key fingerprint 4 + check 4
COUNTER_MAX = const(0xFFFFFFFF)


class AuthError(Exception):
    pass


def cmd_code(name):
    for n, c in CMD_CODES:
        if n == name:
            return c
    raise AuthError("unknown command %r" % name)


def cmd_name(code):
    for n, c in CMD_CODES:
        if c == code:
            return n
    return None


def sha256(data):
    if hashlib is None:
        raise AuthError("no hashlib in this MicroPython build")
    return hashlib.sha256(data).digest()


class Hmac:
    """HMAC-SHA256 (RFC 2104) with the key pads computed once."""

    def __init__(self, key):
        if len(key) < 16:
            raise AuthError("key too short (%d bytes, need >= 16)" % len(key))
        if len(key) > 64:
            key = sha256(key)
        k = bytearray(64)
        k[: len(key)] = key
        self._ipad = bytes(b ^ 0x36 for b in k)
        self._opad = bytes(b ^ 0x5C for b in k)

    def digest(self, msg):
        h = hashlib.sha256(self._ipad)
        h.update(msg)
        inner = h.digest()
        h = hashlib.sha256(self._opad)
        h.update(inner)
        return h.digest()


def hmac_sha256(key, msg):
    return Hmac(key).digest(msg)


def key_fingerprint(key):
    """First 4 bytes of SHA-256 of the key (stored with counters, shown when provisioning)."""
    return sha256(key)[:4]


def equal_ct(a, b):
    """Constant-time comparison of two byte strings."""
    if len(a) != len(b):
        return False
    d = 0
    for i in range(len(a)):
        d |= a[i] ^ b[i]
    return d == 0


# ---------------------------------------------------------------------- persistence
class FileStore:
    """A small state file, replaced atomically: write `path.tmp`, then rename over `path`."""

    def __init__(self, path):
        self.path = path
        self.tmp_path = path + ".tmp"

    def load(self):
        """Bytes of the file, or None when it does not exist."""
        try:
            with open(self.path, "rb") as f:
                return f.read()
        except OSError:
            return None

    def save(self, data):
        import os

        with open(self.tmp_path, "wb") as f:
            f.write(data)
            f.flush()
        os.rename(self.tmp_path, self.path)  # atomic on littlefs and POSIX


class MemStore:
    """In-memory store (tests, and builds without a file system). Survives object re-creation."""

    def __init__(self, data=None):
        self.data = data
        self.fail = False  # tests: make the next save raise OSError

    def load(self):
        return self.data

    def save(self, data):
        if self.fail:
            raise OSError(28)  # ENOSPC
        self.data = bytes(data)


def pack_state(counter, key):
    body = _STATE_MAGIC + struct.pack("<I", counter) + key_fingerprint(key)
    return body + sha256(body)[:4]


def unpack_state(data, key):
    """Counter from a state record. Raises AuthError with the reason when unusable."""
    if data is None:
        raise AuthError("no counter state file: provision this box (docs/HMI.md)")
    if len(data) != _STATE_LEN or data[:4] != _STATE_MAGIC or sha256(data[:12])[:4] != data[12:16]:
        raise AuthError("counter state file corrupt: re-provision (docs/HMI.md)")
    if data[8:12] != key_fingerprint(key):
        raise AuthError("counter state belongs to another key: re-provision (docs/HMI.md)")
    return struct.unpack("<I", data[4:8])[0]


def init_state(store, key, counter=0):
    """Provisioning: write a fresh counter state (boat: last accepted; remote: next counter)."""
    store.save(pack_state(counter, key))


# ---------------------------------------------------------------------- sender (remote box)
class CommandSigner:
    """Builds authenticated command packets with a persisted, never reused counter."""

    def __init__(self, key, boat_id, store, block=32):
        self.mac = Hmac(key)
        self.key = key
        self.boat_id = boat_id
        self.store = store
        self.block = block  # counters reserved per flash write
        # Everything below the persisted value may have been used before a crash: start there.
        self.next = unpack_state(store.load(), key)
        if self.next < 1:
            self.next = 1  # 0 is never valid (the verifier starts with last = 0)
        self.reserved = self.next  # nothing reserved in this boot yet
        self._body = bytearray(BODY_LEN)

    def sign(self, name):
        """Packet (bytes) for command `name`; persists a new counter block first when needed."""
        code = cmd_code(name)
        if self.next >= COUNTER_MAX:
            raise AuthError("counter exhausted: provision a new key")
        if self.next >= self.reserved:
            res = self.next + self.block
            if res > COUNTER_MAX:
                res = COUNTER_MAX
            self.store.save(pack_state(res, self.key))  # raises if it cannot persist: send nothing
            self.reserved = res
        c = self.next
        self.next = c + 1
        b = self._body
        b[0:4] = CMD_MAGIC
        struct.pack_into("<HIB", b, 4, self.boat_id, c, code)
        return bytes(b) + self.mac.digest(b)[:TAG_LEN]


# ---------------------------------------------------------------------- verifier (boat)
class CommandVerifier:
    """Checks command packets; refuses forgeries, replays and garbage, with a reason each time."""

    def __init__(self, key, boat_id, store):
        self.mac = Hmac(key)
        self.key = key
        self.boat_id = boat_id
        self.store = store
        self.accepted = 0
        self.refused = 0
        self.state_error = ""
        try:
            self.last = unpack_state(store.load(), key)
        except AuthError as e:
            self.last = COUNTER_MAX  # refuse everything until provisioned
            self.state_error = str(e)
        self._events = []

    def _refuse(self, reason):
        self.refused += 1
        if len(self._events) < 16:  # bounded; the app drains them into the log
            self._events.append(("AUTH_REFUSED", reason))
        return None, reason

    def drain_events(self):
        ev = self._events
        self._events = []
        return ev

    def verify(self, pkt):
        """Returns (command name, "") when accepted, else (None, reason)."""
        n = len(pkt)
        if n < PKT_LEN:
            return self._refuse("truncated packet (%d bytes, need %d)" % (n, PKT_LEN))
        if n > PKT_LEN:
            return self._refuse("oversize packet (%d bytes)" % n)
        if bytes(pkt[:4]) != CMD_MAGIC:
            return self._refuse("not a command packet (magic)")
        boat_id, counter, code = struct.unpack_from("<HIB", pkt, 4)
        if boat_id != self.boat_id:
            return self._refuse("packet for boat %d, this is boat %d" % (boat_id, self.boat_id))
        tag = self.mac.digest(bytes(pkt[:BODY_LEN]))[:TAG_LEN]
        if not equal_ct(tag, pkt[BODY_LEN:]):
            return self._refuse("bad tag: wrong key or altered packet")
        name = cmd_name(code)
        if name is None:
            return self._refuse("unknown command code %d" % code)
        if self.state_error:
            return self._refuse(self.state_error)
        if counter <= self.last:
            return self._refuse("replay: counter %d <= last accepted %d" % (counter, self.last))
        try:
            self.store.save(pack_state(counter, self.key))  # persisted before it is acted on
        except OSError as e:
            return self._refuse("cannot persist counter (%r): refused" % e)
        self.last = counter
        self.accepted += 1
        return name, ""
