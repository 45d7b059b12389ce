"""Several commissioning trials of one boat pooled into one fit (`trackpilot tune LOG...` when the
logs hold more than one complete trial).

Why: a single 10-minute trial leaves T' too uncertain on about a third of the simulated boats
(docs/COMMISSIONING.md), mostly because the current walks between the low-speed zig-zag and the
circles that measure it. That error is new in every trial, so a second trial halves the variance
instead of repeating the first one's verdict.

How (each trial is fitted alone first, exactly as a single trial is):
- K', T' (in log space), the dead time, the turning radius, the compass lag, the closed heading
  response per RPM (t63) and the pilot's rudder gain: weighted by their inverse variance. When the
  trials disagree by more than their stated uncertainties allow (chi^2 / (n - 1) > 1), the pooled
  1 sigma is widened by sqrt(chi^2 / (n - 1)) (the Birge ratio, as the Particle Data Group scales
  inconsistent measurements), so a pooled value never claims more than the trials agree on. The
  part of the error a boat's trials share (SHARED_REL, SHARED_ABS: measured) is added back, since
  a second trial repeats it.
- The pilot's deadband and damping: the mean, their 1 sigma not reduced (the deadband's stated
  sigma is the method's spread, partly a bias that a second trial repeats).
- The compass offset and deviation, the current: the last trial's (they drift between trials).
- The RPM -> speed map: the mean of the trials' water speeds at each RPM they share.
- A pilot that hunted in any trial: refused as for one trial.
A trial that cannot be fitted at all (a manoeuvre missing) is left out with a note, as long as
one other can.
"""
import copy
import math

from . import tune_fit as F

# The part of each fit's error that a boat's trials share (the dead time standing for the flow lag,
# the pilot model's assumptions, the current's leeway split...), which pooling does not shrink.
# Measured on boats 1-40 of tune_bench, three trials each (noise offsets 0, 1000, 2000): the rms
# of the three trials' mean error beyond what their stated sigmas explain. 1 sigma; relative for
# K', T' and the pilot's gain. A single trial's sigma carries it too (tune_fit's *_SD_MODEL),
# except T''s (5 %: its own sigma covered its error already). Pooled: sd^2 = sd_ivw^2 + shared^2
# (1 - 1/n), so one trial keeps its own sd (docs/COMMISSIONING.md "Pooled trials").
SHARED_REL = {"k_prime": F.K_PRIME_SD_MODEL, "t_prime": 0.05, "pilot_gain": F.PILOT_GAIN_SD_MODEL}
SHARED_ABS = {"radius_m": F.RADIUS_SD_MODEL_M, "compass_lag_s": F.COMPASS_LAG_SD_MODEL_S}


def _with_shared(sd, shared, n):
    """A pooled 1 sigma of n trials with the part they share added back."""
    return math.sqrt(sd * sd + shared * shared * (1.0 - 1.0 / n)) if n > 1 else sd


def pool(values, sds):
    """Inverse-variance mean of `values` with 1-sigma `sds` -> (mean, 1 sigma, Birge ratio >= 1).
    Values whose sd is not finite and positive count only when none has one (plain mean, its
    standard error)."""
    pairs = [(v, s) for v, s in zip(values, sds) if math.isfinite(v) and math.isfinite(s) and s > 0.0]
    if not pairs:
        vs = [v for v in values if math.isfinite(v)]
        if not vs:
            return float("nan"), float("nan"), 1.0
        m = sum(vs) / len(vs)
        if len(vs) < 2:
            return m, float("nan"), 1.0
        sd = math.sqrt(sum((v - m) ** 2 for v in vs) / (len(vs) - 1) / len(vs))
        return m, sd, 1.0
    w = [1.0 / (s * s) for _, s in pairs]
    m = sum(wi * v for wi, (v, _) in zip(w, pairs)) / sum(w)
    sd = 1.0 / math.sqrt(sum(w))
    birge = 1.0
    if len(pairs) > 1:
        chi2 = sum(wi * (v - m) ** 2 for wi, (v, _) in zip(w, pairs))
        birge = max(1.0, math.sqrt(chi2 / (len(pairs) - 1)))
    return m, sd * birge, birge


def _pool_log(values, sds):
    """pool() of positive values in log space (relative sds): (value, 1 sigma, Birge ratio)."""
    logs = [math.log(v) if v > 0 else float("nan") for v in values]
    rel = [s / v if v > 0 else float("nan") for v, s in zip(values, sds)]
    m, s, b = pool(logs, rel)
    v = math.exp(m) if math.isfinite(m) else float("nan")
    return v, v * s, b


def fit_trials(d, length_m=5.0, gnss_latency_s=0.075):
    """Every complete trial of a decoded log fitted, then pooled. One trial: fit_all's result,
    unchanged. TuneError when no trial can be fitted."""
    trials = F.trials_from_decoded(d)
    if len(trials) == 1:
        return F.fit_all(d, length_m, gnss_latency_s, trial=trials[0][1])
    fits, skipped = [], []
    for n, tr, why in trials:
        if tr is None:
            skipped.append((n, "it did not complete (%s)" % why))
            continue
        try:
            fits.append((n, F.fit_all(d, length_m, gnss_latency_s, trial=tr)))
        except F.TuneError as e:
            skipped.append((n, str(e)))
    if not fits:
        n, why = skipped[-1]
        raise F.TuneError("none of the %d trials in the logs can be fitted (trial %d: %s)" % (len(trials), n, why))
    if len(fits) == 1:
        fit = fits[0][1]
        fit["pooled"] = {"trials": 1, "of": len(trials), "used": [fits[0][0]], "skipped": skipped}
        return fit
    return pool_fits(fits, len(trials), skipped)


def _pool_nomoto(fits, birge):
    """K', T' and the dead time pooled over the trials that identified them (a trial whose pilot
    reported no rudder did not); None when none did."""
    if not fits:
        return None
    nom = copy.copy(fits[-1]["nomoto"])
    n = len(fits)
    for key in ("k_prime", "t_prime"):
        v, s, b = _pool_log([f["nomoto"][key] for f in fits], [f["nomoto"][key + "_sd"] for f in fits])
        nom[key], nom[key + "_sd"], birge[key] = v, v * _with_shared(s / v, SHARED_REL[key], n), b
    key = "dead_time_s" if "dead_time_s" in nom else "rudder_lag_s"
    sd_key = key[:-2] + "_sd_s"
    nom[key], nom[sd_key], birge[key] = pool([f["nomoto"][key] for f in fits], [f["nomoto"][sd_key] for f in fits])
    if key == "dead_time_s":  # the simulator's flow lag, as fit_nomoto gives it
        nom["rudder_lag_s"], nom["rudder_lag_sd_s"] = max(0.0, nom["dead_time_s"]), nom["dead_time_sd_s"]
    # the current's part is in each trial's sd; its split and causes belong to one trial each
    for k in [k for k in nom if "_sd_fit" in k or k.endswith("_sd_current") or k == "current_uncertainty"]:
        nom.pop(k)
    nom["windows"] = sum(f["nomoto"]["windows"] for f in fits)
    return nom


def pool_fits(numbered_fits, n_trials=None, skipped=()):
    """[(trial number, fit_all result)] of one boat -> one fit: the last trial's, with the pooled
    values in its place and `pooled` telling what each trial gave."""
    fits = [f for _, f in numbered_fits]
    last = fits[-1]
    fit = dict(last)  # the last trial's data, plots and current; the pooled parts are copies
    per_trial = []
    for n, f in numbered_fits:
        nom, circ, comp = f["nomoto"] or {}, f["circle"], f["compass"]  # {}: no rudder report
        per_trial.append({"trial": n, "start_s": f["trial"]["start_s"], "duration_s": f["trial"]["duration_s"],
                          "k_prime": nom.get("k_prime"), "k_prime_sd": nom.get("k_prime_sd"),
                          "t_prime": nom.get("t_prime"), "t_prime_sd": nom.get("t_prime_sd"),
                          "radius_m": circ["radius_m"], "radius_sd_m": circ["radius_sd_m"],
                          "compass_lag_s": comp["lag_s"], "compass_lag_sd_s": comp["lag_sd_s"],
                          "pilot_gain": f["pilot_gain"].get("gain", 0.0),
                          "problems": list(f["problems"]) + list(f.get("doubts", ()))})
    birge = {}

    n = len(fits)
    nom = _pool_nomoto([f for f in fits if f["nomoto"] is not None], birge)

    circ = copy.copy(last["circle"])
    circ["radius_m"], sd, birge["radius_m"] = pool(
        [f["circle"]["radius_m"] for f in fits], [f["circle"]["radius_sd_m"] for f in fits])
    circ["radius_sd_m"] = _with_shared(sd, SHARED_ABS["radius_m"], n)
    circ["rudder_deg"] = sum(f["circle"]["rudder_deg"] for f in fits) / len(fits)

    comp = copy.copy(last["compass"])
    comp["lag_s"], sd, birge["compass_lag_s"] = pool(
        [f["compass"]["lag_s"] for f in fits], [f["compass"]["lag_sd_s"] for f in fits])
    comp["lag_sd_s"] = _with_shared(sd, SHARED_ABS["compass_lag_s"], n)

    steps = {"by_rpm": {}, "_plot": last["steps"].get("_plot")}
    for rpm, s_last in last["steps"]["by_rpm"].items():
        have = [f["steps"]["by_rpm"][rpm] for f in fits if rpm in f["steps"]["by_rpm"]]
        s = dict(s_last)
        for k in ("delay_s", "t63_s", "tc_s", "overshoot", "gain", "steady_err_deg"):
            s[k], s[k + "_sd"], b = pool([h.get(k, float("nan")) for h in have],
                                         [h.get(k + "_sd", float("nan")) for h in have])
            if k == "t63_s":
                birge["t63_s@%d" % rpm] = b
        s["steps"] = sum(h["steps"] for h in have)
        s["unsettled"] = sum(h["unsettled"] for h in have)
        sw = [h["unsettled_swing_sd_deg"] for h in have if math.isfinite(h.get("unsettled_swing_sd_deg", float("nan")))]
        s["unsettled_swing_sd_deg"] = max(sw) if sw else float("nan")
        s["trials"] = len(have)
        steps["by_rpm"][rpm] = s

    sm = copy.copy(last["speed_map"])
    shared = [r for r in sm["rpm"] if all(r in f["speed_map"]["rpm"] for f in fits)]
    if len(shared) >= 2:
        speeds = [sum(f["speed_map"]["speed_mps"][f["speed_map"]["rpm"].index(r)] for f in fits) / len(fits)
                  for r in shared]
        k = (shared[-1] - shared[0]) / max(1e-6, speeds[-1] - speeds[0])
        sm.update(rpm=shared, speed_mps=speeds, rpm_per_mps=float(k), rpm_offset=float(shared[0] - k * speeds[0]),
                  speed_sd_mps=[float("nan")] * len(shared))

    pg = copy.copy(last["pilot_gain"])
    claimed = [f["pilot_gain"] for f in fits if f["pilot_gain"].get("gain", 0.0) > 0.0]
    if claimed:
        # the last trial that claimed a gain (the last one may not have: too few large errors, no
        # rudder report), with its report counts; the pooled numbers in its place
        pg = copy.copy(claimed[-1])
        g, g_sd, birge["pilot_gain"] = _pool_log([c["gain"] for c in claimed], [c["gain_sd"] for c in claimed])
        g_sd = g * _with_shared(g_sd / g, SHARED_REL["pilot_gain"], len(claimed))
        pg.update(gain=g, gain_sd=g_sd, pooled_from=len(claimed))
        pg.pop("why", None)
        for k, sd_k in (("damping_s", "damping_sd_s"), ("deadband_deg", "deadband_sd_deg"), ("ram_dps", None)):
            pg[k] = sum(c[k] for c in claimed) / len(claimed)
            if sd_k:
                pg[sd_k] = max(c[sd_k] for c in claimed)  # not reduced: see the module's note
        if not g_sd / g <= F.PILOT_GAIN_SD_MAX:
            pg.update(gain=0.0, why="the gain is uncertain (1 sigma %.0f %%, %d trials pooled): sail another "
                                    "trial" % (100 * g_sd / g, len(claimed)))

    fit.update(nomoto=nom, circle=circ, compass=comp, steps=steps, speed_map=sm, pilot_gain=pg)
    with_rudder = [f for f in fits if not (f.get("rudder") or {}).get("absent")]
    if with_rudder:  # the sign the configuration gets: from the last trial that saw the rudder
        fit["rudder"] = with_rudder[-1].get("rudder")
    fit["_trial"] = dict(last["_trial"], hunts=[])  # hunts are each trial's own (below)
    fit["pooled"] = {"trials": len(fits), "of": n_trials or len(fits), "used": [n for n, _ in numbered_fits],
                     "skipped": list(skipped), "per_trial": per_trial, "birge": birge}
    problems = F.uncertainty_problems(fit, pooled=len(fits))
    for n, f in numbered_fits:
        problems += ["trial %d: %s" % (n, p) for p in f["problems"] if p.startswith("the pilot hunted")]
    fit["problems"] = problems
    fit["doubts"] = F.model_doubts(fit, pooled=len(fits))
    F.derive_all(fit)
    fit["warnings"] += disagreements(birge)
    return fit


# a Birge ratio beyond this: the trials differ by more than noise (3 sigma for two trials)
DISAGREE_BIRGE = 3.0
_NAMES = {"k_prime": "K'", "t_prime": "T'", "radius_m": "the turning radius", "compass_lag_s": "the compass lag",
          "pilot_gain": "the pilot's gain", "dead_time_s": "the dead time", "rudder_lag_s": "the rudder lag"}


def disagreements(birge):
    """Warnings for pooled values whose trials disagree far beyond their uncertainties."""
    bad = ["%s (x%.1f)" % (_NAMES.get(k, k), b) for k, b in sorted(birge.items())
           if b > DISAGREE_BIRGE and not k.startswith("t63")]
    if not bad:
        return []
    return ["the trials disagree on %s far beyond their uncertainties (the Birge ratio in brackets; the "
            "pooled sigma is widened by it): was the boat's load or trim, the pilot's response setting or "
            "the compass changed between the trials? Pool only trials of the boat as it will sail"
            % ", ".join(bad)]
