# Authenticated commands: HMAC vectors, valid command, replays (also after a verifier reboot),
# wrong key, truncated/garbage packets, counters that survive crashes of the sender.
import tpassert as T

try:
    import hashlib
except ImportError:
    hashlib = None
    print("skipped: no hashlib")

KEY = b"0123456789abcdef0123456789abcdef"
OTHER = b"fedcba9876543210fedcba9876543210"


def _files():
    """FileStores in /tmp when this build has files and os, else MemStores (same semantics)."""
    from tphmi.auth import FileStore, MemStore

    try:
        import os
        import time

        base = "/tmp/tphmi_auth_%d_" % time.ticks_us()
        rx, tx = FileStore(base + "rx.bin"), FileStore(base + "tx.bin")
        return rx, tx, [rx.path, tx.path]
    except ImportError:
        print("note: no os/time: MemStore instead of files")
        return MemStore(), MemStore(), []


def _cleanup(paths):
    import os

    for p in paths:
        for q in (p, p + ".tmp"):
            try:
                os.remove(q)
            except OSError:
                pass


def _pair(rx=None, tx=None):
    from tphmi.auth import CommandSigner, CommandVerifier, init_state

    if rx is None:
        rx, tx, paths = _files()
    init_state(rx, KEY, 0)
    init_state(tx, KEY, 0)
    return CommandVerifier(KEY, 7, rx), CommandSigner(KEY, 7, tx), rx, tx


def test_hmac_rfc4231():
    if hashlib is None:
        return
    from tphmi.auth import hmac_sha256

    T.eq(hmac_sha256(b"\x0b" * 20, b"Hi There"),
         bytes.fromhex("b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7"))
    # case 6: key longer than the block size
    T.eq(hmac_sha256(b"\xaa" * 131, b"Test Using Larger Than Block-Size Key - Hash Key First"),
         bytes.fromhex("60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54"))


def test_valid_command_and_replay_refused():
    if hashlib is None:
        return
    v, s, rx, tx = _pair()
    try:
        for name in ("ENGAGE", "STANDBY", "NEXT_WP", "PREV_WP", "ACK"):
            pkt = s.sign(name)
            T.eq(len(pkt), 27)
            T.eq(v.verify(pkt), (name, ""))
        cmd, why = v.verify(pkt)
        T.eq(cmd, None)
        T.true(why.startswith("replay"), why)
        T.eq(v.accepted, 5)
        T.eq(v.refused, 1)
        T.eq(v.drain_events(), [("AUTH_REFUSED", why)])
    finally:
        if hasattr(rx, "path"):
            _cleanup([rx.path, tx.path])


def test_replay_refused_after_verifier_reboot():
    if hashlib is None:
        return
    from tphmi.auth import CommandVerifier

    v, s, rx, tx = _pair()
    try:
        old = s.sign("ENGAGE")
        newer = s.sign("STANDBY")
        T.eq(v.verify(old)[0], "ENGAGE")
        T.eq(v.verify(newer)[0], "STANDBY")
        v2 = CommandVerifier(KEY, 7, rx)  # the boat reboots: state from the file
        cmd, why = v2.verify(old)
        T.eq(cmd, None)
        T.true(why.startswith("replay"), why)
        T.eq(v2.verify(newer)[0], None)
        T.eq(v2.verify(s.sign("ACK"))[0], "ACK", "fresh commands still work")
    finally:
        if hasattr(rx, "path"):
            _cleanup([rx.path, tx.path])


def test_sender_reboot_never_reuses_counter():
    if hashlib is None:
        return
    import struct
    from tphmi.auth import CommandSigner

    v, s, rx, tx = _pair()
    try:
        used = []
        for _ in range(5):
            used.append(struct.unpack("<I", s.sign("ACK")[6:10])[0])
        s2 = CommandSigner(KEY, 7, tx)  # the remote crashes and reboots
        c = struct.unpack("<I", s2.sign("ACK")[6:10])[0]
        T.true(c > max(used), "counter %d after reboot, used up to %d" % (c, max(used)))
        for _ in range(100):  # across several reserved blocks
            s2.sign("ACK")
        s3 = CommandSigner(KEY, 7, tx)
        pkt = s3.sign("STANDBY")
        T.eq(v.verify(pkt)[0], "STANDBY")
    finally:
        if hasattr(rx, "path"):
            _cleanup([rx.path, tx.path])


def test_wrong_key_wrong_boat_altered_truncated_garbage():
    if hashlib is None:
        return
    from tphmi.auth import CommandSigner, MemStore, init_state

    v, s, rx, tx = _pair(MemStore(), MemStore())
    evil_store = MemStore()
    init_state(evil_store, OTHER, 100)
    evil = CommandSigner(OTHER, 7, evil_store)
    cmd, why = v.verify(evil.sign("ENGAGE"))
    T.eq(cmd, None)
    T.true("bad tag" in why, why)
    other_boat = MemStore()
    init_state(other_boat, KEY, 0)
    cmd, why = v.verify(CommandSigner(KEY, 8, other_boat).sign("ENGAGE"))
    T.true(cmd is None and "boat 8" in why, why)
    good = s.sign("ENGAGE")
    for i, what in ((10, "command"), (6, "counter"), (20, "tag")):
        b = bytearray(good)
        b[i] ^= 0x01
        cmd, why = v.verify(bytes(b))
        T.true(cmd is None and "bad tag" in why, "altered %s: %s" % (what, why))
    for n in (0, 1, 11, 26):
        cmd, why = v.verify(good[:n])
        T.true(cmd is None and "truncated" in why, why)
    cmd, why = v.verify(good + b"\x00")
    T.true(cmd is None and "oversize" in why, why)
    cmd, why = v.verify(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
    T.true(cmd is None and "magic" in why, why)
    T.eq(v.state_error, "")
    T.eq(v.verify(good)[0], "ENGAGE", "the genuine packet still works after all that")
    T.eq(v.refused, 11)


def test_missing_corrupt_or_foreign_state_refuses_everything():
    if hashlib is None:
        return
    from tphmi.auth import AuthError, CommandSigner, CommandVerifier, MemStore, init_state, pack_state

    _, s, _, _ = _pair(MemStore(), MemStore())
    pkt = s.sign("ENGAGE")
    v = CommandVerifier(KEY, 7, MemStore(None))
    cmd, why = v.verify(pkt)
    T.true(cmd is None and "provision" in why, why)
    bad = bytearray(pack_state(0, KEY))
    bad[5] ^= 1
    v = CommandVerifier(KEY, 7, MemStore(bytes(bad)))
    T.true("corrupt" in v.verify(pkt)[1])
    v = CommandVerifier(KEY, 7, MemStore(pack_state(0, OTHER)))
    T.true("another key" in v.verify(pkt)[1])
    T.raises(AuthError, CommandSigner, KEY, 7, MemStore(None))


def test_persist_failure_refuses():
    if hashlib is None:
        return
    from tphmi.auth import MemStore

    v, s, rx, tx = _pair(MemStore(), MemStore())
    rx.fail = True
    cmd, why = v.verify(s.sign("ENGAGE"))
    T.true(cmd is None and "persist" in why, why)
    rx.fail = False
    tx.fail = True
    for _ in range(40):  # the first block is already reserved; the next reservation fails
        try:
            s.sign("ACK")
        except OSError:
            break
    else:
        raise AssertionError("signer sent without persisting its counter block")
