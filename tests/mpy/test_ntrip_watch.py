# Issue 14.6: the supervisor restarts an NTRIP client task that ended (it never should).
import tpassert as T

try:
    from trackpilot.app import App
except ImportError:  # a port without asyncio (the f32 build before i13a's asyncio work)
    App = None
    print("skipped: no asyncio, trackpilot.app does not import")


class _Task:
    def __init__(self, done):
        self._done = done

    def done(self):
        return self._done


class _Stop:
    def is_set(self):
        return False


class _FakeApp:
    def __init__(self, done):
        self.ntrip_task = _Task(done)
        self.ntrip_restarts = 0
        self.stop_event = _Stop()
        self.events = []
        self.started = 0

    def event(self, kind, text):
        self.events.append((kind, text))

    def start_ntrip(self):
        self.started += 1
        self.ntrip_task = _Task(False)


def test_supervisor_restarts_an_ended_ntrip_task():
    if App is None:
        return
    a = _FakeApp(True)
    App.watch_ntrip(a)
    T.eq(a.started, 1)
    T.eq(a.events[0][0], "FAULT")
    App.watch_ntrip(a)  # running again: left alone
    T.eq(a.started, 1)


def test_running_ntrip_task_is_left_alone():
    if App is None:
        return
    a = _FakeApp(False)
    App.watch_ntrip(a)
    T.eq(a.started, 0)
    T.eq(a.events, [])
