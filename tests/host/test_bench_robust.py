"""The robustness benchmark: parameter spreads, the oscillation metric, and the sweep on a real
Dask scheduler with two workers on loopback (one killed mid-sweep), same numbers as one worker."""
import math
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from trackpilot_tools import bench_robust as BR
from trackpilot_tools.sim import params as P


def test_spread_draw_is_seeded_within_ranges_and_nominal_unchanged():
    sp = P.load_spread()
    nom = P.load()
    assert "spread" not in nom
    assert nom["boat"]["rudder_lag_s"] == 0.0 and nom["boat"]["speed_map_scale"] == 1.0
    assert nom["pilot"]["compass_dev_sin_deg"] == 0.0 and nom["pilot"]["compass_dev_cos_deg"] == 0.0
    a_over, a = P.draw_spread(7, sp, nom)
    b_over, b = P.draw_spread(7, sp, nom)
    _, c = P.draw_spread(8, sp, nom)
    assert a == b and a_over == b_over and a != c
    for name, spec in sp.items():
        lo, hi = spec["range"]
        sec, _, key = name.partition(".")
        v = a[name]
        if spec["kind"] == "scale":
            f = a_over[sec][key] / nom[sec][key]
            assert lo - 1e-3 <= f <= hi + 1e-3, name
        else:
            assert lo - 0.5 <= v <= hi + 0.5, name
    # every range in the issue is there
    for name in ("pilot.kp_rudder_per_deg", "pilot.kd_rudder_s", "pilot.deadband_deg", "pilot.rudder_rate_degps",
                 "pilot.key_delay_ms", "pilot.compass_lag_s", "pilot.compass_offset_deg", "pilot.compass_dev_sin_deg",
                 "boat.k_prime", "boat.t_prime", "boat.rudder_lag_s", "wind.leeway_frac", "boat.speed_map_scale",
                 "boat.surge_tau_s", "gnss.latency_ms", "gnss.heading_sd_deg_at_1m", "water.current_mps",
                 "wind.speed_mps", "water.wave_yaw_rms_deg"):
        assert name in sp and sp[name]["why"], name


def _sine(amp0, keep_per_half, period_s=20.0, n_s=200.0, offset=0.3):
    out = []
    t = 0.0
    while t < n_s:
        half = int(t / (period_s / 2))
        out.append((t, offset + amp0 * keep_per_half ** half * math.sin(2 * math.pi * t / period_s)))
        t += 0.2
    return out


def test_oscillation_metric():
    assert BR.oscillation(_sine(2.0, 0.85))["oscillates"]  # the case: -15 % per half cycle
    o = BR.oscillation(_sine(2.0, 1.0))
    assert o["oscillates"] and abs(o["period_s"] - 20.0) < 1.0 and 1.8 < o["amp_m"] <= 2.0
    assert not BR.oscillation(_sine(2.0, 0.3))["oscillates"]  # well damped
    assert not BR.oscillation(_sine(0.4, 1.0))["oscillates"]  # below 0.5 m
    assert not BR.oscillation([(k * 0.2, 1.2) for k in range(500)])["oscillates"]  # a steady offset
    # irregular swings (period doubling each time) are not a regular oscillation
    sig, t, s = [], 0.0, 1
    for half in (3.0, 7.0, 15.0, 31.0, 63.0):
        n = int(half / 0.2)
        sig += [(t + k * 0.2, s * 1.5 * math.sin(math.pi * k / n)) for k in range(n)]
        t += half
        s = -s
    assert not BR.oscillation(sig)["oscillates"]


def test_settled_late_rms_is_the_second_half_of_the_window():
    # the end of an approach (0.4 m for 20 s) then a steady 0.1 m for 20 s: the window's RMS is
    # the approach's, its second half the steady state's
    after = [(30.0 + k * 0.2, 0.4 if k < 100 else 0.1) for k in range(200)]
    assert BR.settled_late_rms(after) == 0.1
    assert BR.settled_late_rms([]) is None
    # by time, not by samples: a gap in the second half does not move the midpoint
    gap = [(t, x) for t, x in after if not 45.0 < t < 55.0]
    assert BR.settled_late_rms(gap) == 0.1


def test_outside_by_phase():
    """Each sample outside 1.5 m lands in exactly one phase; corners at 50 and 100 m of track."""
    rows = [(k * 0.5, x, s, s, True) for k, (x, s) in enumerate([
        (3.0, 0.0), (2.0, 2.0),  # approach: before the first sample within 1.5 m
        (1.0, 4.0), (2.0, 10.0),  # back in; then out on the first leg (start, straight)
        (0.5, 30.0), (1.6, 40.0), (-2.0, 55.0),  # inside; two out within 15 m of the corner at 50
        (1.7, 70.0), (1.4, 75.0), (1.8, 90.0),  # out 20 m past it (exit); 90: near the next corner
        (1.9, 140.0), (0.0, 150.0)])]  # 40 m past the last corner: straight
    o = BR.outside_by_phase(rows, [50.0, 100.0])
    n = len(rows)
    assert o["out_approach_pct"] == round(100.0 * 2 / n, 2)
    assert o["out_corner_pct"] == round(100.0 * 3 / n, 2)
    assert o["out_exit_pct"] == round(100.0 * 1 / n, 2)
    assert o["out_straight_pct"] == round(100.0 * 2 / n, 2)
    assert o["out_start_pct"] == round(100.0 * 1 / n, 2)


def _free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def _strip(res):
    m = dict(res["metrics"])
    m.pop("wall_s", None)
    return (res["job"]["case"], res["job"]["boat"]), m, res["params"]


def test_sweep_on_a_real_scheduler_with_a_killed_worker_gives_the_same_numbers(tmp_path):
    dask_cli = Path(sys.executable).with_name("dask")
    if not dask_cli.exists():
        pytest.skip("dask command not installed (make setup)")
    port = _free_port()
    addr = "tcp://127.0.0.1:%d" % port
    procs = []

    def start(*args):
        p = subprocess.Popen([str(dask_cli), *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
        procs.append(p)
        return p

    jobs = [{"case": "straight_3.0", "law": "los", "boat": b, "timeout": 120.0} for b in (1, 2, 3, 4)]
    try:
        start("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
        time.sleep(2.0)
        w1 = start("worker", addr, "--nthreads", "1", "--no-nanny", "--no-dashboard", "--name", "w1")
        start("worker", addr, "--nthreads", "1", "--no-nanny", "--no-dashboard", "--name", "w2")
        from dask.distributed import Client

        with Client(addr, timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
        got = []
        for _, res in BR.run_on_dask(jobs, BR.run_job, scheduler=addr):
            got.append(res)
            if len(got) == 1:
                os.kill(w1.pid, signal.SIGKILL)  # its task is rescheduled on the other worker
        assert len(got) == 4 and not any("error" in r for r in got)
    finally:
        for p in procs:
            try:
                os.killpg(p.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
    one = [res for _, res in BR.run_on_dask(jobs, BR.run_job, scheduler=None, workers=1)]
    a = sorted(_strip(r) for r in got)
    b = sorted(_strip(r) for r in one)
    assert a == b
    assert all(r["metrics"]["finished"] for r in got)
