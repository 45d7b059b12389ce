"""A minimal firmware for the simulator's own tests (runs under MicroPython with the real simio):
reports STANDBY, on ENGAGE sends the Auto key on SeaTalk with the right parities, steps the course
+10 once later, sets 400 RPM every 200 ms, and counts GNSS bytes. Not the application."""
import sys

from trackpilot.sim.simio import SimLink

link = SimLink(sys.stdin.buffer, sys.stdout.buffer)
asyncio = link.install()
stop = asyncio.Event()
link.stop_callback = stop.set
state = {"gnss": 0, "engaged": False}


def st_write(data):
    st = link.stream(2)
    for i, b in enumerate(data):
        ones = bin(b).count("1") & 1
        cmd = 1 if i == 0 else 0
        st.init(parity=0 if ones == cmd else 1)  # 0 even, 1 odd
        st.write(bytes((b,)))


async def gnss():
    r = asyncio.StreamReader(link.stream(1))
    while True:
        b = await r.read(512)
        state["gnss"] += len(b)


async def inputs():
    io = link.stream(5)
    io.write(b"mode=STANDBY\n")
    r = asyncio.StreamReader(io)
    while True:
        line = await r.read(64)
        if b"button=ENGAGE" in line and not state["engaged"]:
            state["engaged"] = True
            st_write(b"\x86\x11\x01\xfe")
            io.write(b"mode=AUTO\n")
            await asyncio.sleep_ms(5000)
            st_write(b"\x86\x11\x08\xf7")


async def motor():
    m = link.stream(3)
    while True:
        m.write(b"S400\r")
        await asyncio.sleep_ms(200)


async def main():
    for f in (gnss, inputs, motor):
        asyncio.create_task(f())
    await stop.wait()
    sys.stderr.write("fake firmware: gnss bytes %d\n" % state["gnss"])


asyncio.run(main())
