"""Entry point of the firmware in simulation (docs/SIM_PROTOCOL.md).

    micropython firmware/sim_main.py --config CFG.json --track TRACK.csv --data DIR [--seed N]
                                     [--profile] [--heap-stages [--heap-every S]]

Runs the same App as main.py on the ESP32; only the wiring and the clock/event-loop adapter differ.
Diagnostics go to stderr; stdout carries the protocol.
"""
import sys


def _args(argv):
    opts = {"--config": None, "--track": None, "--data": "/tmp/trackpilot_sim", "--seed": "1",
            "--reset-cause": "power-on", "--tick-base": None, "--quiet": None, "--profile": None,
            "--heap-stages": None, "--heap-every": "600", "--journal": None}
    i = 1
    while i < len(argv):
        a = argv[i]
        if a in ("--quiet", "--profile", "--heap-stages"):
            opts[a] = "1"
            i += 1
            continue
        if a not in opts or i + 1 >= len(argv):
            raise SystemExit("sim_main: unknown or incomplete option %s" % a)
        opts[a] = argv[i + 1]
        i += 2
    return opts


def largest_free_block():
    """The largest free block of the heap (bytes), from the project's host builds (gcinfo, see
    tools/README.md); None elsewhere (finding it by allocating can pin the block found)."""
    try:
        import gcinfo
    except ImportError:
        return None
    return gcinfo.info()[3]


def heap_stage(name):
    """One line of the start-up heap table on stderr (--heap-stages): live heap after a
    collection, free heap and the largest free block; on the frozen-firmware build also the part
    of the live heap that is the loader's records of the frozen code (in flash on an ESP32
    image: tools/README.md, docs/MEMORY.md)."""
    import gc

    gc.collect()
    live = gc.mem_alloc()
    free = gc.mem_free()
    big = largest_free_block()
    try:
        import gcinfo

        loader = gcinfo.loader()[0]
    except (ImportError, AttributeError):
        loader = 0
    sys.stderr.write("sim_main: heap stage %-16s live %6d B, free %6d B, largest free block %6s B%s\n" % (
        name, live, free, "-" if big is None else big,
        ", frozen-code records %6d B" % loader if loader else ""))


_gc_last = [0, 0, 0]  # (simulated ms, collections, their CPU us) at the previous gc_stage


def gc_stage(name, t_ms):
    """--heap-stages on the f32 builds: the collections since the previous call (the app's own
    and those its gc.threshold triggers), per simulated minute, and their CPU time on this host."""
    try:
        import gcinfo

        n, cpu_us, max_us = gcinfo.collections(True)
    except (ImportError, AttributeError):
        return
    dn = n - _gc_last[1]
    dt_s = (t_ms - _gc_last[0]) / 1000
    if dn > 0 and dt_s > 0:
        sys.stderr.write("sim_main: gc stage %-16s %d collections in %d s simulated, %.1f per minute, CPU mean %d us, "
                         "max %d us (host)\n" % (name, dn, dt_s, dn * 60 / dt_s, (cpu_us - _gc_last[2]) // dn, max_us))
    _gc_last[0] = t_ms
    _gc_last[1] = n
    _gc_last[2] = cpu_us


async def _heap_watch(link, app, every_s):
    """--heap-stages: the heap once the tasks run, then in steady state (every every_s, 600 s
    unless --heap-every says)."""
    import asyncio

    await asyncio.sleep_ms(0)
    heap_stage("tasks started")
    gc_stage("tasks started", link.t_ms)
    while True:
        await asyncio.sleep_ms(every_s * 1000)
        gc_stage("t=%d s" % (link.t_ms // 1000), link.t_ms)
        heap_stage("t=%d s" % (link.t_ms // 1000))


def main():
    opts = _args(sys.argv)
    stages = opts["--heap-stages"]
    if stages:
        heap_stage("interpreter")
    from trackpilot import config
    from trackpilot.sim.simio import SimLink
    from trackpilot.sim.wiring_sim import Wiring

    if opts["--config"]:
        cfg, problems = config.load(opts["--config"])
    else:
        cfg, problems = config.defaults(), ["no --config: built-in defaults"]
    if stages:
        heap_stage("config")
    base = int(opts["--tick-base"]) if opts["--tick-base"] else (1 << 30) - 60000
    link = SimLink(sys.stdin.buffer, sys.stdout.buffer, tick_base=base)
    asyncio = link.install()
    wiring = Wiring(link, opts["--data"], seed=int(opts["--seed"]), quiet=bool(opts["--quiet"]))
    if stages:
        heap_stage("asyncio, wiring")
    from trackpilot.app import App

    if stages:
        heap_stage("app imported")
    journal = None
    if opts["--journal"]:  # every input of the decision core, for tools/replay_core.py
        from trackpilot.sim.journal import journaling

        journal = open(opts["--journal"], "a")
        journal.write("B %s\n" % opts["--seed"])
        app = App(wiring, cfg, problems, reset_cause=opts["--reset-cause"], core_class=journaling(journal))
    else:
        app = App(wiring, cfg, problems, reset_cause=opts["--reset-cause"])
    if stages:
        heap_stage("App()")
    if opts["--profile"]:
        app.profile = True
        app.profile_out = open(opts["--data"] + "/profile.txt", "w")
    link.stop_callback = app.stop_event.set
    if opts["--track"]:
        app.load_track(opts["--track"])
        if stages:
            heap_stage("track loaded")
    if stages:
        async def _run():
            asyncio.create_task(_heap_watch(link, app, int(opts["--heap-every"])))
            await app.run()

        asyncio.run(_run())
        heap_stage("stopped")
        # the modules the run imported (tools/romfs_heap.py estimates their loader records)
        sys.stderr.write("sim_main: modules %s\n" % " ".join(sorted(sys.modules)))
    else:
        asyncio.run(app.run())
    if journal is not None:
        journal.close()
    import gc

    gc.collect()
    sys.stderr.write("sim_main: stopped at t=%d ms, epochs %d, peak heap %d B (live, after a collection), heap now %d B "
                     "used / %d B free, GC runs %d, max GC pause %d us\n" % (
                         link.t_ms, app.epochs, app.peak_heap, gc.mem_alloc(), gc.mem_free(),
                         app.gc_runs, app.gc_max_us))
    if app.profile:
        try:
            _profile_report(app, opts["--data"])
        except MemoryError:  # the summary sorts every sample; the samples are in the file anyway
            app.profile_out = None
            sys.stderr.write("sim_main: profile: no summary (MemoryError in a small heap); samples in %s\n" % (
                opts["--data"] + "/profile.txt"))


def _profile_report(app, data_dir):
    """Per control epoch (GNSS feed + control_step): CPU us and bytes allocated; every sample is
    in DATA/profile.txt ("us bytes" a line), a summary goes to stderr."""
    app.profile_flush()
    app.profile_out.close()
    us = []
    al = []
    with open(data_dir + "/profile.txt") as f:
        for line in f:
            a, _, b = line.partition(" ")
            us.append(int(a))
            al.append(int(b))
    n = len(us)
    if not n:
        return
    us.sort()
    al.sort()
    sys.stderr.write("sim_main: profile: %d epochs, CPU us median %d p99 %d max %d, allocated B median %d "
                     "p99 %d max %d mean %d\n" % (n, us[n // 2], us[n * 99 // 100], us[-1], al[n // 2],
                                                  al[n * 99 // 100], al[-1], sum(al) // n))


try:
    main()
except SystemExit:
    raise
except BaseException as e:  # the protocol owns stdout: tracebacks go to stderr
    sys.print_exception(e, sys.stderr)
    sys.exit(1)
