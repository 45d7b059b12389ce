# The app's receiver configuration session (ubxcfg.ConfigSession): its end is logged once, and the
# finished session (frames, log) is released, as are the parser's acknowledgement callbacks
# (docs/MEMORY.md "What was cut"); a late ACK after that is ignored.
import tpassert as t
from _appwiring import HAVE_ASYNCIO, Wiring
from trackpilot import config
from trackpilot.devices import gnss, ubxcfg

DIR = "/tmp/trackpilot_test_app_gnss_cfg"


class _Uart:
    def __init__(self):
        self.out = []

    def write(self, b):
        self.out.append(bytes(b))


class _Wiring(Wiring):
    def __init__(self):
        Wiring.__init__(self, DIR)
        self.gnss_uart = _Uart()


def _ack(app, frame, ack=True):
    r = app.gnss.ack
    r.cls = frame[2]
    r.id = frame[3]
    app.gnss.on_msg(gnss.K_ACK_ACK if ack else gnss.K_ACK_NAK)


def _app_in_session():
    """An App whose receiver configuration session has sent its first frame (the GNSS task's
    pump coroutine itself is not run); (wiring, app), or None without asyncio."""
    if not HAVE_ASYNCIO:
        print("skipped: no asyncio")
        return None
    from trackpilot.app import App

    w = _Wiring()
    app = App(w, config.defaults(), ())
    app.task_gnss().close()
    return w, app


def test_finished_session_is_released():
    made = _app_in_session()
    if made is None:
        return
    w, app = made
    frames = list(app.gnss_cfg.frames)
    t.eq(w.gnss_uart.out, [frames[0]])
    for k in range(len(frames)):
        w.t += 20
        _ack(app, frames[k])
    t.eq(app.gnss_cfg.state, ubxcfg.DONE)
    w.t += 100
    app.gnss_config_poll(w.t)
    done = [x for x in w.lines if "receiver configuration" in x]
    t.eq(len(done), 1)
    t.true("done: configuration done" in done[0], done[0])
    t.eq(app.gnss_cfg, None)
    t.eq(app.gnss.on_msg, None)
    t.eq(app.gnss_cfg_failed, False)
    app._on_gnss_msg(gnss.K_ACK_ACK)  # a late one: nothing sent, nothing raised
    t.eq(len(w.gnss_uart.out), len(frames))
    app.log.close()


def test_failed_session_is_reported_then_released():
    made = _app_in_session()
    if made is None:
        return
    w, app = made
    frame = app.gnss_cfg.frames[0]
    for _ in range(app.gnss_cfg.retries + 1):
        w.t += 10
        _ack(app, frame, ack=False)
    app.gnss_config_poll(w.t)
    t.true(any("receiver configuration FAILED" in x for x in w.lines), w.lines)
    t.eq(app.gnss_cfg_failed, True)
    t.eq(app.gnss_cfg, None)
    app.log.close()
