"""End to end: the firmware sails a commissioning trial against the simulated boat, `trackpilot
tune` fits it, `trackpilot sim --boat` sails the fitted boat with the tuned configuration; and
tune's refusals on logs without a complete trial."""
import json
import math
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

from trackpilot_tools import cli  # noqa: E402
from trackpilot_tools.sim.runner import SimRun  # noqa: E402

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON

TRACK = ROOT / "tracks" / "middelburg_loop.csv"


def _trial(out, **kw):
    run = SimRun(TRACK, out, seed=3, scenario="calm", duration_s=kw.pop("duration_s", 700), trial=True, **kw)
    run.run()
    return run, sorted((out / "fw" / "log").glob("*.tpl"))


def _cli(argv):
    try:
        return cli.main(argv)
    except SystemExit as e:
        return e.code


@pytest.fixture(scope="module")
def trial_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("trial")
    run, logs = _trial(out)
    return run, logs


def test_trial_tune_sim(trial_run, tmp_path, capsys):
    run, logs = trial_run
    assert run.trial_seen and run.stop_reason == "finished", run.stop_reason
    rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "tune"), "--no-plots"])
    assert rc == 0, capsys.readouterr().err
    fit = json.loads((tmp_path / "tune" / "fit.json").read_text())
    truth = run.p
    assert fit["nomoto"]["k_prime"] == pytest.approx(truth["boat"]["k_prime"], rel=0.15)
    assert fit["nomoto"]["t_prime"] == pytest.approx(truth["boat"]["t_prime"], rel=0.15)
    assert fit["compass"]["lag_s"] == pytest.approx(truth["pilot"]["compass_lag_s"], abs=0.15)
    assert fit["trial"]["duration_s"] <= 600
    # the pilot's own loop from its reports (tune_fit.fit_pilot_gain), into the simulator's pilot
    assert fit["pilot_gain"]["gain"] == pytest.approx(truth["pilot"]["kp_rudder_per_deg"], rel=0.15), fit["pilot_gain"]
    assert fit["pilot_gain"]["damping_s"] == pytest.approx(truth["pilot"]["kd_rudder_s"], rel=0.5), fit["pilot_gain"]
    assert "pooled" not in fit  # one trial: nothing pooled
    cfg = json.loads((tmp_path / "tune" / "config.json").read_text())
    assert cfg["boat"]["min_turn_radius_m"] > 5
    # the simulator sails the fitted boat with the tuned configuration
    rc = _cli(["sim", str(TRACK), "--boat", str(tmp_path / "tune" / "fit.json"),
               "--fw-config", str(tmp_path / "tune" / "config.json"), "--duration-s", "150",
               "--out", str(tmp_path / "sim"), "--no-plots"])
    assert rc == 0
    params = json.loads((tmp_path / "sim" / "sim_params.json").read_text())
    assert params["boat"]["k_prime"] == pytest.approx(fit["nomoto"]["k_prime"], rel=1e-3)
    assert params["pilot"]["compass_lag_s"] == pytest.approx(fit["compass"]["lag_s"], abs=1e-3)
    assert params["pilot"]["kp_rudder_per_deg"] == pytest.approx(fit["pilot_gain"]["gain"], rel=1e-3)
    assert params["pilot"]["kd_rudder_s"] == pytest.approx(fit["pilot_gain"]["damping_s"], rel=1e-3)
    summ = json.loads((tmp_path / "sim" / "summary.json").read_text())
    text = json.dumps(summ)
    assert "AUTO" in text


def test_two_trials_are_pooled(trial_run, tmp_path, capsys):
    """The same boat's trial sailed again (another day's waves, gusts, current walk and noise), its
    log in a folder of its own (the flash numbered it 0001 again): tune fits each, pools them, and
    says so; the pooled T' is narrower than either trial's and between them."""
    from trackpilot_tools import logdecode
    from trackpilot_tools import tune_fit as F
    from trackpilot_tools import tune_pool as TP

    run, logs = trial_run
    out2 = tmp_path / "day2"
    again = SimRun(TRACK, out2, seed=1003, scenario="calm", duration_s=700, trial=True)
    again.run()
    logs2 = sorted((out2 / "fw" / "log").glob("*.tpl"))
    assert again.trial_seen and [p.name for p in logs2] == [p.name for p in logs]
    rc = _cli(["tune", *map(str, logs), *map(str, logs2), "--out", str(tmp_path / "tune"), "--no-plots"])
    assert rc == 0, capsys.readouterr().err
    fit = json.loads((tmp_path / "tune" / "fit.json").read_text())
    pooled = fit["pooled"]
    assert pooled["trials"] == 2 and pooled["used"] == [1, 2] and not pooled["skipped"]
    singles = [F.fit_all(logdecode.decode_files(x)) for x in (logs, logs2)]
    t_primes = sorted(f["nomoto"]["t_prime"] for f in singles)
    assert [t["t_prime"] for t in pooled["per_trial"]] == pytest.approx([f["nomoto"]["t_prime"] for f in singles])
    assert t_primes[0] <= fit["nomoto"]["t_prime"] <= t_primes[1]
    # its 1 sigma: the trials' inverse-variance one (x the Birge ratio), with their shared part added back
    rel = [f["nomoto"]["t_prime_sd"] / f["nomoto"]["t_prime"] for f in singles]
    ivw = pooled["birge"]["t_prime"] / math.sqrt(sum(1.0 / (r * r) for r in rel))
    want = math.sqrt(ivw ** 2 + TP.SHARED_REL["t_prime"] ** 2 / 2)
    assert fit["nomoto"]["t_prime_sd"] / fit["nomoto"]["t_prime"] == pytest.approx(want, rel=1e-6)
    assert want < max(rel) or pooled["birge"]["t_prime"] > 1.0
    assert fit["nomoto"]["t_prime"] == pytest.approx(run.p["boat"]["t_prime"], rel=0.15)
    # the current and the compass offset are the last trial's; the configuration validates
    assert fit["current"]["speed_mps"] == pytest.approx(singles[1]["current"]["speed_mps"])
    assert json.loads((tmp_path / "tune" / "config.json").read_text())["boat"]["min_turn_radius_m"] > 5
    report = (tmp_path / "tune" / "report.md").read_text()
    assert "2 trials pooled" in report and "Birge ratio" in report
    # the same log given twice (or a copy of it) is used once: a trial is never pooled with itself
    copy = tmp_path / "copy" / "0001-00.tpl"
    copy.parent.mkdir()
    copy.write_bytes(logs[0].read_bytes())
    capsys.readouterr()
    rc = _cli(["tune", str(logs[0]), str(copy), "--out", str(tmp_path / "once"), "--no-plots"])
    assert rc == 0 and "is the same log as" in capsys.readouterr().out
    assert "pooled" not in json.loads((tmp_path / "once" / "fit.json").read_text())
    # a cut second trial is left out, with a note, and the first one fitted alone
    data = b"".join(p.read_bytes() for p in logs2)
    d2 = logdecode.decode_files(logs2)
    end = [e for e in d2.events if e.kind == "TRIAL" and e.text.startswith("end")][0]
    cut = tmp_path / "cut" / "0001-00.tpl"
    cut.parent.mkdir()
    cut.write_bytes(data[:end.offset])
    rc = _cli(["tune", *map(str, logs), str(cut), "--out", str(tmp_path / "tune1"), "--no-plots"])
    assert rc == 0, capsys.readouterr().err
    fit1 = json.loads((tmp_path / "tune1" / "fit.json").read_text())
    assert fit1["pooled"]["trials"] == 1 and fit1["pooled"]["used"] == [1]
    assert [n for n, _ in fit1["pooled"]["skipped"]] == [2]
    assert fit1["nomoto"]["t_prime"] == pytest.approx(singles[0]["nomoto"]["t_prime"])  # as alone
    assert "Trial 2 of the logs not used: it did not complete" in (tmp_path / "tune1" / "report.md").read_text()


def test_tune_bench_checks_everything_the_trial_identifies(trial_run):
    """tune_bench compares the compass offset (the one the compass showed: its drift included) and
    deviation, the RPM -> speed map, the current and the closed heading response with the
    simulator's, beside Nomoto."""
    from trackpilot_tools import tune_bench

    run, _ = trial_run
    row = tune_bench.fit_boat({"seed": 3}, run.out, run.p)
    f, t = row["fit"], row["truth"]
    assert t["offset_deg"] != run.p["pilot"]["compass_offset_deg"]  # measured, not the drawn value
    assert abs(f["offset_deg"] - t["offset_deg"]) < 1.0
    assert abs(f["dev_sin_deg"] - t["dev_sin_deg"]) < 1.0 and abs(f["dev_cos_deg"] - t["dev_cos_deg"]) < 1.0
    assert len(f["speed_mps"]) == len(t["speed_mps"]) >= 2
    for got, want in zip(f["speed_mps"], t["speed_mps"]):
        assert got == pytest.approx(want, rel=0.15)
    assert abs(f["current_e_mps"] - t["current_e_mps"]) < 0.03 and abs(f["current_n_mps"] - t["current_n_mps"]) < 0.03
    # the closed heading response per RPM against the pilot alone on the true boat in quiet water:
    # the lowest RPM's time to 63 % was 24 % long (5.26 s for 4.25) before the key time came from
    # the keys sent and the levels from a fitted model
    assert set(f["steps"]) == set(t["steps"]) and len(f["steps"]) >= 2
    low = min(f["steps"], key=int)
    assert f["steps"][low]["t63_s"] == pytest.approx(t["steps"][low]["t63_s"], rel=0.15), (f["steps"], t["steps"])
    text = tune_bench.table([row])
    for key in ("offset_deg", "dev_sin_deg", "speed_mps", "current", "step t63_s"):
        assert key in text, text


def test_trial_with_the_low_speed_circle_tune_sim(tmp_path, capsys):
    """trial.circle_low_turns: a circle right after the low-speed zig-zag; tune fits a current for
    it and one for the circles at the end, and the result sails."""
    low = {"circle_low_turns": 1, "straight_s": 30, "circle_max_s": 60}
    run, logs = _trial(tmp_path / "trial", fw_config={"trial": low})
    assert run.trial_seen and run.stop_reason == "finished", run.stop_reason
    rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "tune"), "--no-plots"])
    assert rc == 0, capsys.readouterr().err
    fit = json.loads((tmp_path / "tune" / "fit.json").read_text())
    assert fit["trial"]["duration_s"] <= 600
    circles = [m for m in fit["trial"]["manoeuvres"] if m[0] == "circle"]
    assert len(circles) == 3
    zz_low = [m for m in fit["trial"]["manoeuvres"] if m[0] == "zigzag"][0]
    assert 0 <= circles[0][1] - zz_low[2] < 2.0  # right after the low-speed zig-zag
    assert len(fit["current"]["by_time"]) == 2
    truth = run.p
    assert fit["nomoto"]["t_prime"] == pytest.approx(truth["boat"]["t_prime"], rel=0.15)
    assert fit["nomoto"]["k_prime"] == pytest.approx(truth["boat"]["k_prime"], rel=0.15)
    assert "by circle group" in (tmp_path / "tune" / "report.md").read_text()
    rc = _cli(["sim", str(TRACK), "--boat", str(tmp_path / "tune" / "fit.json"),
               "--fw-config", str(tmp_path / "tune" / "config.json"), "--duration-s", "60",
               "--out", str(tmp_path / "sim"), "--no-plots"])
    assert rc == 0


def test_a_reversed_rudder_report_is_found_and_configured(tmp_path, capsys):
    """A pilot whose 0x84/0x9C rudder byte is + = steer left (the sign is not confirmed on the
    ST2000+): tune finds it from the circles, fits as usual and writes pilot.rudder_sign -1; with
    that the firmware logs the rudder the right way round and tune keeps -1."""
    reversed_pilot = {"pilot": {"rudder_report_sign": -1}}
    run, logs = _trial(tmp_path / "t1", overrides=reversed_pilot)
    assert run.stop_reason == "finished", run.stop_reason
    rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "tune1"), "--no-plots"])
    out = capsys.readouterr().out
    assert rc == 0
    fit = json.loads((tmp_path / "tune1" / "fit.json").read_text())
    assert fit["rudder"] == {"sign": -1, "logged": 1, "reversed": True, "agree": fit["rudder"]["agree"]}
    assert fit["rudder"]["agree"] > 0.9
    assert fit["nomoto"]["k_prime"] == pytest.approx(run.p["boat"]["k_prime"], rel=0.15)
    assert fit["nomoto"]["t_prime"] == pytest.approx(run.p["boat"]["t_prime"], rel=0.15)
    assert "rudder report has the other sign" in out
    cfg = json.loads((tmp_path / "tune1" / "config.json").read_text())
    assert cfg["pilot"]["rudder_sign"] == -1
    run2, logs2 = _trial(tmp_path / "t2", overrides=reversed_pilot, fw_config={"pilot": cfg["pilot"]})
    assert run2.stop_reason == "finished", run2.stop_reason
    rc = _cli(["tune", *map(str, logs2), "--out", str(tmp_path / "tune2"), "--no-plots"])
    out = capsys.readouterr().out
    assert rc == 0
    fit2 = json.loads((tmp_path / "tune2" / "fit.json").read_text())
    assert (fit2["rudder"]["sign"], fit2["rudder"]["logged"], fit2["rudder"]["reversed"]) == (-1, -1, False)
    assert "other sign" not in out


def test_a_pilot_without_a_rudder_report_still_gets_its_configuration(trial_run, tmp_path, capsys):
    """A tiller pilot may put 0 in the 0x84 rudder byte: K', T' and its own gain cannot be fitted,
    but everything the configuration takes (turning radius, RPM map, closed heading response) is;
    `sim --boat` and `tune --sweep` say why they cannot sail that fit."""
    run, logs = _trial(tmp_path / "t", overrides={"pilot": {"rudder_report_sign": 0}})
    assert run.stop_reason == "finished", run.stop_reason
    rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "tune"), "--no-plots"])
    out = capsys.readouterr().out
    assert rc == 0
    fit = json.loads((tmp_path / "tune" / "fit.json").read_text())
    assert fit["nomoto"] is None and fit["sim_params"] is None
    assert "no rudder angle" in fit["rudder"]["absent"]
    assert "not identified" in out and "no rudder angle" in out
    cfg = json.loads((tmp_path / "tune" / "config.json").read_text())
    assert "pilot" not in cfg  # the sign is not known
    assert cfg["boat"]["min_turn_radius_m"] > 5
    assert fit["circle"]["radius_m"] == pytest.approx(run.p["boat"]["length_m"] / (
        run.p["boat"]["k_prime"] * math.radians(run.p["pilot"]["rudder_limit_deg"])), rel=0.15)
    assert cfg["guidance"]["los_alos_gain"] > 0 and cfg["motor"]["rpm_per_mps"] > 0
    rc = _cli(["sim", str(TRACK), "--boat", str(tmp_path / "tune" / "fit.json"), "--duration-s", "10",
               "--out", str(tmp_path / "sim"), "--no-plots"])
    err = capsys.readouterr().err
    assert rc != 0 and "cannot be sailed" in err and "Traceback" not in err
    rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "tune2"), "--no-plots", "--sweep", "2"])
    err = capsys.readouterr().err
    assert rc != 0 and "--sweep" in err and "Traceback" not in err
    # pooled after a trial that had the rudder (the last trial's pilot gain not claimed): K', T'
    # and the gain from the first, the report says which trial had none
    _, with_rudder = trial_run
    rc = _cli(["tune", *map(str, with_rudder), *map(str, logs), "--out", str(tmp_path / "tune3"),
               "--no-plots", "--force"])
    out = capsys.readouterr().out
    assert rc == 0
    fit = json.loads((tmp_path / "tune3" / "fit.json").read_text())
    assert fit["pooled"]["trials"] == 2 and fit["nomoto"]["k_prime"] > 0
    assert fit["pooled"]["per_trial"][1]["k_prime"] is None and "no rudder report" in out
    assert fit["pilot_gain"]["gain"] > 0 and "scored" in fit["pilot_gain"]
    assert json.loads((tmp_path / "tune3" / "config.json").read_text())["pilot"]["rudder_sign"] == 1


def test_tune_sweep_around_the_fit(trial_run, tmp_path, capsys):
    """--sweep on a tiny N: boats drawn around the fit sail the tuned and the default guidance on
    the robust bench's engine; config.json is the recommended one."""
    from trackpilot_tools import tune_sweep as S

    run, logs = trial_run
    rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "tune"), "--no-plots", "--force",
               "--sweep", "2", "--jobs", "1"])
    assert rc == 0, capsys.readouterr().err
    out = tmp_path / "tune"
    sweep = json.loads((out / "sweep.json").read_text())
    assert set(sweep["summary"]) == {"tuned", "default"}
    assert all(s["runs"] == 2 for s in sweep["summary"].values())
    by = {(r["config"], r["boat"]): r for r in sweep["runs"]}
    assert set(by) == {("tuned", 1), ("tuned", 2), ("default", 1), ("default", 2)}
    # the same boat for both configurations, drawn around the fit
    assert by[("tuned", 1)]["drawn"] == by[("default", 1)]["drawn"]
    fit = json.loads((out / "fit.json").read_text())
    name, _why = fit["recommended"]
    cfg = json.loads((out / "config.json").read_text())
    tuned = json.loads((out / "config_tuned.json").read_text())
    if name == "tuned":
        assert cfg == tuned
    else:
        assert cfg["guidance"] == {"law": "los"} and cfg["boat"] == tuned["boat"]
    assert name == S.recommend(sweep["summary"])[0]
    assert "Recommended: %s" % name in (out / "report.md").read_text()
    # draws: within a few sigma of the fit (the pilot's gain too, 10 %), the rest of the pilot from the spreads
    boats = S.draw_boats(fit, 3)
    n = fit["nomoto"]
    for _seed, p, _flat in boats:
        assert abs(p["boat"]["k_prime"] - n["k_prime"]) <= 5 * n["k_prime_sd"] + 1e-9
    assert len({p["pilot"]["kp_rudder_per_deg"] for _s, p, _f in boats}) == 3
    # the damping around the fitted one (log-normal, x0.7..1.4 at 1 sigma), not the spread's
    kd = fit["sim_params"]["pilot"]["kd_rudder_s"]
    for _seed, p, flat in boats:
        assert kd * math.exp(-4 * S.KD_LOG_SD) <= p["pilot"]["kd_rudder_s"] <= kd * math.exp(4 * S.KD_LOG_SD)
        assert flat["pilot.kd_rudder_s"] == p["pilot"]["kd_rudder_s"]


def test_tune_refuses_a_cut_trial(trial_run, tmp_path, capsys):
    """A log cut before the trial's end: a plain one-line refusal naming the cause, nothing written."""
    from trackpilot_tools import logdecode

    run, logs = trial_run
    data = b"".join(p.read_bytes() for p in logs)
    d = logdecode.decode_files(logs)
    end = [e for e in d.events if e.kind == "TRIAL" and e.text.startswith("end")][0]
    cut = tmp_path / "cut.tpl"
    cut.write_bytes(data[:end.offset])
    rc = _cli(["tune", str(cut), "--out", str(tmp_path / "t")])
    err = capsys.readouterr().err
    assert rc == 2
    assert "did not complete" in err and "Traceback" not in err
    assert not (tmp_path / "t").exists()


def test_tune_refuses_a_trial_in_which_the_pilot_hunted(tmp_path, capsys):
    """A pilot whose own loop limit-cycles (gain x2, damping x0.3, a slow compass: inside the
    robust bench's spreads): the firmware's pilot watch reports it during the trial, and tune
    refuses with what to change on the pilot, not "repeat the manoeuvre"."""
    from trackpilot_tools import logdecode

    out = tmp_path / "hunts"
    run, logs = _trial(out, overrides={"pilot": {"kp_rudder_per_deg": 2.4, "kd_rudder_s": 0.45,
                                                 "compass_lag_s": 1.0}})
    assert run.trial_seen and run.stop_reason == "finished", run.stop_reason
    d = logdecode.decode_files(logs)
    assert any(e.kind == "PILOT" and e.text.startswith("pilot hunts") for e in d.events)
    rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "t"), "--no-plots"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "the pilot hunted during the trial" in err and "lower its response/rudder gain" in err
    assert "Traceback" not in err


def test_a_trial_aborted_by_an_alarm_is_refused_with_the_alarm(tmp_path, capsys):
    """A pilot whose ram barely moves (0.4 deg/s: less than the 10 deg a window needs to count
    as steering) cannot turn the boat through the trial's course steps: the firmware's hang check
    raises pilot_hang, the mode machine ends the trial, and tune's refusal quotes that reason (not
    the trial's own "stopped: mode STANDBY") and says what to check."""
    out = tmp_path / "weak"
    run, logs = _trial(out, duration_s=300, overrides={"pilot": {"kp_rudder_per_deg": 0.25, "deadband_deg": 3.0,
                                                                 "rudder_rate_degps": 0.4}})
    rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "t")])
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err
    assert "did not complete (trial aborted by alarm pilot_hang" in err, err
    assert "check its response/rudder gain setting" in err


def test_tune_refuses_a_log_without_trial(tmp_path, capsys):
    out = tmp_path / "auto"
    run = SimRun(TRACK, out, seed=1, scenario="calm", duration_s=40)
    run.run()
    logs = sorted((out / "fw" / "log").glob("*.tpl"))
    rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "t")])
    err = capsys.readouterr().err
    assert rc == 2
    assert "no commissioning trial" in err



def test_tune_arguments_out_of_range_are_plain_errors(trial_run, tmp_path, capsys):
    # --length-m 1e9 was an OverflowError traceback; a negative or NaN latency was taken, or
    # blamed on the log ("too few compass readings")
    _run, logs = trial_run
    for opt, value, want in (("--length-m", "1e9", "--length-m"), ("--length-m", "0", "--length-m"),
                             ("--length-m", "nan", "--length-m"), ("--gnss-latency-ms", "-100", "--gnss-latency-ms"),
                             ("--gnss-latency-ms", "1e9", "--gnss-latency-ms"), ("--gnss-latency-ms", "nan", "--gnss-latency-ms")):
        rc = _cli(["tune", *map(str, logs), "--out", str(tmp_path / "t"), "--no-plots", opt, value])
        err = capsys.readouterr().err
        assert rc == 2, (opt, value)
        assert want in err and "Traceback" not in err, err
    assert not (tmp_path / "t").exists()  # nothing written

def test_sim_boat_bad_file_is_a_plain_error(tmp_path, capsys):
    bad = tmp_path / "fit.json"
    bad.write_text("{}")
    rc = _cli(["sim", str(TRACK), "--boat", str(bad), "--out", str(tmp_path / "s")])
    assert rc == 2
    assert "no sim_params" in capsys.readouterr().err


def test_sim_boat_says_how_sure_the_fitted_boat_is(tmp_path, capsys):
    """A fit whose T' is beyond its limit but within what tune accepts (only the simulated boat
    takes it): `sim --boat` sails it and repeats tune's doubt, with the manoeuvre to sail again,
    once (the fit is read twice: the inputs' check, then the sail)."""
    from trackpilot_tools.sim_cmd import boat_overrides, say_boat_doubts

    doubt = ("for the simulated boat only: T' too uncertain (+-14 %, 1 sigma, limit 10 %): repeat the "
             "zig-zag and the turning circles")
    fit = tmp_path / "fit.json"
    fit.write_text(json.dumps({"sim_params": {"boat": {"k_prime": 1.0, "t_prime": 0.5}}, "doubts": [doubt]}))
    assert boat_overrides(str(fit)) == {"boat": {"k_prime": 1.0, "t_prime": 0.5}}
    assert capsys.readouterr().err == ""  # the loader itself says nothing: each command says it once
    say_boat_doubts(str(fit))
    assert doubt in capsys.readouterr().err
    rc = _cli(["sim", str(TRACK), "--boat", str(fit), "--duration-s", "5", "--out", str(tmp_path / "s"),
               "--no-plots"])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert err.count(doubt) == 1
    fit.write_text(json.dumps({"sim_params": {"boat": {"k_prime": 1.0, "t_prime": 0.5}}, "doubts": []}))
    say_boat_doubts(str(fit))
    assert capsys.readouterr().err == ""
