# Runs the firmware NTRIP client under MicroPython against a caster on loopback; prints results.
import sys
import asyncio
import time
from trackpilot.devices import ntrip

port = int(sys.argv[1])
mount = sys.argv[2]
want = int(sys.argv[3])
keep_going = len(sys.argv) > 4 and sys.argv[4] == "keep"  # do not stop at a refusal: reconnect
frames = []
events = []
stop = asyncio.Event()


def forward(frame):
    frames.append(frame)
    if len(frames) >= want:
        stop.set()


def ev(kind, text):
    events.append(text)
    if ("not found" in text or "refused" in text) and not keep_going:
        stop.set()


async def main():
    cfg = {"host": "127.0.0.1", "port": port, "mountpoint": mount, "user": "boat", "password": "secret",
           "gga_interval_s": 0}
    task = asyncio.create_task(ntrip.run_client(cfg, forward, time.ticks_ms, events=ev, stop=stop))
    try:
        await asyncio.wait_for(stop.wait(), 10)
    except asyncio.TimeoutError:
        pass
    task.cancel()
    s = ntrip.current_session()
    print("frames", len(frames))
    print("bytes", sum(len(f) for f in frames))
    print("bad_crc", s.bad_crc)
    print("age_ok", s.age_s(time.ticks_ms()) is not None and s.age_s(time.ticks_ms()) < 5)
    for e in events:
        print("event", e)


asyncio.run(main())
