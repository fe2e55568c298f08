#!/usr/bin/env python3
"""Markdown table of kcrig's benchmark figures next to their peers'.

Reads the Google Benchmark JSON files that scripts/bench.sh writes to
build/bench/ (model_bench, estimator_bench, designer_bench, diagnosis_bench,
rt_bench, can_round_trip_vcan) and prints one row per comparison: kcrig's
figure, the peer's (MINPACK lmder, SUNDIALS CVODE, cyclictest, ...) and the
ratio kcrig / peer, plus the figures of Table 1 of Butz, Simeon and Stadler
where the paper gives them (their machine, their model: see the note under
the table).

Times are wall-clock (real_time), the median where the file has repetitions
(aggregate "median"); latency distributions come from counters (p50_us ...).
A file or a benchmark that is missing, unreadable or skipped makes its row
say "not run"; the script never fails on the data.

  python3 scripts/bench_table.py                       print the table
  python3 scripts/bench_table.py --update docs/benchmarks.md    also rewrite the part
      between <!-- bench-table:begin --> and <!-- bench-table:end -->
      (temp file + rename: the file is never half-written)
  --dir DIR    where the JSON files are (default: build/bench of this repo)

Python 3 standard library only.
"""
import argparse
import json
import math
import os
import re
import statistics
import sys
import tempfile
from pathlib import Path

BEGIN = "<!-- bench-table:begin -->"
END = "<!-- bench-table:end -->"
FILES = ("model_bench", "estimator_bench", "designer_bench", "diagnosis_bench",
         "rt_bench", "can_round_trip_vcan")
NOT_RUN = "not run"
DASH = "—"
TIME_UNITS = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}
# Keys of a benchmark entry that are not user counters.
STANDARD_KEYS = {
    "name", "run_name", "run_type", "repetitions", "repetition_index",
    "threads", "iterations", "real_time", "cpu_time", "time_unit",
    "aggregate_name", "aggregate_unit", "family_index",
    "per_family_instance_index", "label", "error_occurred", "error_message",
    "bytes_per_second", "items_per_second", "big_o", "rms",
}
# Name parts Google Benchmark appends to a benchmark's own name.
DECORATION = re.compile(
    r"^(iterations|repeats|threads|min_time|min_warmup_time):|"
    r"^(real_time|manual_time|process_time)$")

# The paper's Table 1 (Butz, Simeon, Stadler): CPU seconds on a 3.0 GHz dual
# Pentium 4 PC, the DYNA4 model (MATLAB/Simulink), gradients by finite
# differences.
PAPER = {
    ("D", "DACE+SNOPT"): dict(nev=186, cpu=6915, phi=14.93, z=-0.5),
    ("D", "IFFCO"): dict(nev=138, cpu=5180, phi=13.11, z=-0.5),
    ("A", "DACE+SNOPT"): dict(nev=186, cpu=7024, phi=3.12, z=-0.44),
    ("A", "IFFCO"): dict(nev=252, cpu=9403, phi=4.54, z=-0.41),
}


# ---------------------------------------------------------------- reading


class Bench:
    """One benchmark: wall time [s] and counters, median over repetitions."""

    def __init__(self, seconds, counters, error=None):
        self.seconds = seconds
        self.counters = counters
        self.error = error

    def counter(self, name):
        value = self.counters.get(name)
        return value if isinstance(value, (int, float)) else None


def base_name(entry):
    name = entry.get("run_name") or entry.get("name", "")
    if entry.get("run_type") == "aggregate" and "run_name" not in entry:
        name = re.sub(r"_(mean|median|stddev|cv)$", "", name)
    parts = [p for p in name.split("/") if not DECORATION.search(p)]
    return "/".join(parts)


def pairs_keeping_duplicates(pairs):
    """A counter named like a standard key (`iterations`) follows it in the
    same object: keep it as `counter:NAME`."""
    out = {}
    for key, value in pairs:
        out["counter:" + key if key in out else key] = value
    return out


def load_json(path):
    """The JSON document in `path`, or None. Tolerates text around it (a
    file captured from a VM's console)."""
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    try:
        doc = json.loads(text, object_pairs_hook=pairs_keeping_duplicates)
    except ValueError:
        start = text.find("{")
        doc = None
        while start >= 0 and doc is None:
            try:
                doc, _ = json.JSONDecoder(
                    object_pairs_hook=pairs_keeping_duplicates).raw_decode(
                        text, start)
            except ValueError:
                start = text.find("{", start + 1)
    if not isinstance(doc, dict) or not isinstance(doc.get("benchmarks"), list):
        return None
    return doc


def seconds_of(entry):
    try:
        return float(entry["real_time"]) * TIME_UNITS[entry.get("time_unit", "ns")]
    except (KeyError, TypeError, ValueError):
        return None


def counters_of(entry):
    return {k: v for k, v in entry.items()
            if k not in STANDARD_KEYS and isinstance(v, (int, float))
            and not isinstance(v, bool)}


def index(doc):
    """name -> Bench, preferring the `median` aggregate, else the median of
    the plain repetitions."""
    medians, runs, errors = {}, {}, {}
    for entry in doc.get("benchmarks", []):
        if not isinstance(entry, dict):
            continue
        name = base_name(entry)
        if entry.get("error_occurred"):
            errors[name] = str(entry.get("error_message") or "error")
            continue
        if entry.get("run_type") == "aggregate":
            if entry.get("aggregate_name") == "median":
                medians[name] = Bench(seconds_of(entry), counters_of(entry))
        else:
            runs.setdefault(name, []).append(entry)
    out = {}
    for name, entries in runs.items():
        times = [t for t in map(seconds_of, entries) if t is not None]
        keys = set().union(*(counters_of(e) for e in entries))
        counters = {}
        for k in keys:
            values = [e[k] for e in entries if isinstance(e.get(k), (int, float))]
            counters[k] = statistics.median(values)
        out[name] = Bench(statistics.median(times) if times else None, counters)
    out.update(medians)
    for name, message in errors.items():
        if name not in out:
            out[name] = Bench(None, {}, error=message)
    return out


class Data:
    def __init__(self, directory):
        self.directory = directory
        self.docs, self.benches = {}, {}
        for f in FILES:
            doc = load_json(Path(directory) / (f + ".json"))
            if doc is not None:
                self.docs[f] = doc
                self.benches[f] = index(doc)

    def get(self, f, name):
        """The Bench, or None when not run or failed."""
        b = self.benches.get(f, {}).get(name)
        if b is None or b.error is not None:
            return None
        return b

    def why_not(self, f, name):
        b = self.benches.get(f, {}).get(name)
        if b is not None and b.error is not None:
            return "%s (skipped: %s)" % (NOT_RUN, b.error)
        return NOT_RUN


# ------------------------------------------------------------- formatting


def num(v, digits=3):
    """A number with `digits` significant digits, plain when that reads."""
    if v is None or not math.isfinite(v):
        return "?"
    if v == 0:
        return "0"
    a = abs(v)
    if 1e-3 <= a < 1e5:
        decimals = max(0, digits - 1 - int(f"{a:e}".split("e")[1]))
        return f"{v:.{decimals}f}"
    return sci(v, digits - 1)


def sci(v, decimals=1):
    if v is None or not math.isfinite(v):
        return "?"
    mantissa, exponent = f"{v:.{decimals}e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def duration(seconds):
    if seconds is None:
        return "?"
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("µs", 1e-7)):
        if abs(seconds) >= scale:
            return f"{num(seconds / (1e-6 if unit == 'µs' else scale))} {unit}"
    return f"{num(seconds / 1e-9)} ns"


def micros(us):
    return duration(None if us is None else us * 1e-6)


def ratio(a, b):
    if a is None or b is None or b == 0:
        return DASH
    r = a / b
    if not math.isfinite(r):
        return DASH
    return f"{r:.2f}" if 0.01 <= abs(r) < 100 else sci(r)


def count(v):
    """An integer count, thousands separated by a thin space (24 006)."""
    if v is None or not math.isfinite(v):
        return "?"
    return f"{int(round(v)):,}".replace(",", "\u202f")


# ------------------------------------------------------------------- rows


def rows(d):
    out = []

    def row(quantity, kcrig, peer=DASH, peer_figure=DASH, r=DASH, note=""):
        out.append((quantity, kcrig, peer, peer_figure, r, note))

    # model_bench
    step = d.get("model_bench", "BM_SemiImplicitEulerStep")
    row("one semi-implicit Euler step, `double`",
        duration(step.seconds) if step else d.why_not("model_bench", "BM_SemiImplicitEulerStep"),
        note="target ≤ 2 µs")

    plain = d.get("model_bench", "BM_Trajectory4sDouble")
    cvode = d.get("model_bench", "BM_Trajectory4sCvodeMatchedAccuracy")
    note = ""
    if cvode:
        note = ("CVODE rtol %s: %s steps, %s RHS evaluations; max error %s σ "
                "(semi-implicit Euler at h = 1 ms: %s σ)" % (
                    sci(cvode.counter("rtol")), count(cvode.counter("cvode_steps")),
                    count(cvode.counter("cvode_rhs_evals")),
                    num(cvode.counter("cvode_error_sigma"), 2),
                    num(cvode.counter("semi_implicit_error_sigma"), 2)))
    row("4 s ramp at 1 kHz (4000 steps), `double`",
        duration(plain.seconds) if plain else d.why_not("model_bench", "BM_Trajectory4sDouble"),
        "SUNDIALS CVODE (BDF) at matched accuracy",
        duration(cvode.seconds) if cvode else d.why_not("model_bench", "BM_Trajectory4sCvodeMatchedAccuracy"),
        ratio(plain and plain.seconds, cvode and cvode.seconds), note)

    jet = d.get("model_bench", "BM_Trajectory4sJetSensitivities")
    note = "the reference"
    if jet and plain and jet.seconds and plain.seconds:
        note += "; %s× the `double` trajectory" % num(jet.seconds / plain.seconds, 2)
    row("same with exact sensitivities for the 5 stiffnesses, `Jet<5>`",
        duration(jet.seconds) if jet else d.why_not("model_bench", "BM_Trajectory4sJetSensitivities"),
        note=note)

    tl = d.get("model_bench", "BM_Trajectory4sTangentLinearSensitivities")
    note = "target ≤ 2.5× the `double` trajectory (#18)"
    if tl and plain and tl.seconds and plain.seconds:
        note += "; %s× it" % num(tl.seconds / plain.seconds, 2)
    row("same by the tangent-linear step (what kcrig runs)",
        duration(tl.seconds) if tl else d.why_not("model_bench", "BM_Trajectory4sTangentLinearSensitivities"),
        "`Jet<5>`",
        duration(jet.seconds) if jet else d.why_not("model_bench", "BM_Trajectory4sJetSensitivities"),
        ratio(tl and tl.seconds, jet and jet.seconds), note)

    tl2 = d.get("model_bench", "BM_Trajectory4sTangentLinearSensitivitiesTwoThreads")
    row("same split 3 ‖ 2 directions on two threads (wall)",
        duration(tl2.seconds) if tl2 else d.why_not("model_bench", "BM_Trajectory4sTangentLinearSensitivitiesTwoThreads"),
        "one thread",
        duration(tl.seconds) if tl else d.why_not("model_bench", "BM_Trajectory4sTangentLinearSensitivities"),
        ratio(tl2 and tl2.seconds, tl and tl.seconds),
        "the split repeats the part all directions share: the estimator runs one trajectory")

    # estimator_bench
    def fit(b):
        text = "%s, max rel. error %s" % (duration(b.seconds),
                                          sci(b.counter("max_rel_error")))
        if b.counter("counter:iterations") is not None:
            text += ", %s iterations" % count(b.counter("counter:iterations"))
        return text

    lm = d.get("estimator_bench", "BM_KcrigExactSensitivityLM")
    lm_text = d.why_not("estimator_bench", "BM_KcrigExactSensitivityLM")
    if lm:
        lm_text = fit(lm)
    cov = d.get("estimator_bench", "BM_CovarianceAndIdentifiability")
    residuals = count(cov.counter("rows")) if cov and cov.counter("rows") else "24\u202f006"
    minpack = d.get("estimator_bench", "BM_MinpackLmderForwardDifference")
    minpack_text = d.why_not("estimator_bench", "BM_MinpackLmderForwardDifference")
    if minpack:
        minpack_text = fit(minpack)
        if minpack.counter("simulations") is not None:
            minpack_text += ", %s simulations" % count(minpack.counter("simulations"))
    row("first estimation: %s residuals × 5 stiffnesses, start 5 %% off, "
        "noise-free" % residuals, lm_text,
        "MINPACK `lmder` + forward-difference Jacobian (the paper's code)",
        minpack_text, ratio(lm and lm.seconds, minpack and minpack.seconds),
        "kcrig: Ceres LM on exact tangent-linear sensitivities; paper §5.1: estimates "
        "within 0.1 %, no time given")
    numeric = d.get("estimator_bench", "BM_CeresNumericDiffLM")
    row("same", lm_text, "Ceres LM, numeric (central) differences",
        fit(numeric) if numeric else d.why_not("estimator_bench", "BM_CeresNumericDiffLM"),
        ratio(lm and lm.seconds, numeric and numeric.seconds))
    row("covariance + identifiability analysis (SVD of the %s × 5 "
        "Jacobian)" % residuals,
        duration(cov.seconds) if cov else d.why_not("estimator_bench", "BM_CovarianceAndIdentifiability"))

    # designer_bench
    single = d.get("designer_bench", "BM_CriterionEvaluation")
    batch = d.get("designer_bench", "BM_CriterionEvaluationBatchOfTwo")
    per_design = batch.seconds / 2 if batch and batch.seconds else None
    row("one criterion evaluation (trajectory + 5 sensitivities + "
        "criterion), per design",
        "%s in two-design batches, one per core" % duration(per_design)
        if batch else d.why_not("designer_bench", "BM_CriterionEvaluationBatchOfTwo"),
        "one design at a time",
        duration(single.seconds) if single else d.why_not("designer_bench", "BM_CriterionEvaluation"),
        ratio(per_design, single and single.seconds))

    def design(b):
        return "%s evaluations, %s → %s°, %s m" % (
            count(b.counter("evaluations")), duration(b.seconds),
            num(b.counter("phi_deg"), 3), f"{b.counter('z_a'):.3f}"
            if b.counter("z_a") is not None else "?")

    paper_note = ("paper: CPU time, 3.0 GHz dual Pentium 4, DYNA4 model "
                  "with finite differences; Φ scaled differently")
    for criterion, label in (("D", "D-optimal"), ("A", "A-optimal")):
        for algo, name, paper_algo in (
                ("kriging", "kriging", "DACE+SNOPT"),
                ("imfil", "imfil", "IFFCO"),
                ("nlopt_direct_l", "NLopt DIRECT-L + BOBYQA", None)):
            key = "BM_Optimizer/%s_%s" % (criterion, algo)
            b = d.get("designer_bench", key)
            quantity = "%s design from (85°, -0.45 m), %s" % (label, name)
            kcrig = design(b) if b else d.why_not("designer_bench", key)
            if paper_algo is None:
                row(quantity, kcrig)
                continue
            p = PAPER[(criterion, paper_algo)]
            r = DASH
            if b and b.counter("evaluations"):
                r = "nEv %s; time %s" % (ratio(b.counter("evaluations"), p["nev"]),
                                         ratio(b.seconds, p["cpu"]))
            row(quantity, kcrig, "paper Table 1: %s" % paper_algo,
                "%d evaluations, %d s CPU → %s°, %s m" % (
                    p["nev"], p["cpu"], p["phi"], p["z"]), r, paper_note)
    for criterion in ("E", "MM"):
        key = "BM_Optimizer/%s_nlopt_slsqp_epigraph" % criterion
        b = d.get("designer_bench", key)
        row("%s-optimal design, epigraph form, NLopt SLSQP" % criterion,
            design(b) if b else d.why_not("designer_bench", key),
            note="paper §5.2: E and confidence-interval criteria behave like "
                 "A, not optimised" if criterion == "E" else "")

    exact = d.get("designer_bench", "BM_CriterionNoise/exact_sensitivities")
    fd = d.get("designer_bench", "BM_CriterionNoise/forward_differences_1e_6")

    def noise(b, key):
        if not b:
            return d.why_not("designer_bench", key)
        text = sci(b.counter("relative_noise"))
        if b.counter("estimated") == 0:
            text += " (ECnoise: not resolved)"
        return text

    row("noise of Φ_A along a line (ECnoise, relative), exact sensitivities",
        noise(exact, "BM_CriterionNoise/exact_sensitivities"),
        "forward-difference sensitivities, step 1e-6",
        noise(fd, "BM_CriterionNoise/forward_differences_1e_6"),
        ratio(exact and exact.counter("relative_noise"),
              fd and fd.counter("relative_noise")),
        "paper §5.2: DYNA4 gives ≈ 8 valid digits; its A surface is noisy")
    sil_name = "BM_Campaign/default_no_effect"
    pure_name = "BM_Campaign/default_no_effect_pure_simulation"
    sil = d.get("designer_bench", sil_name)
    pure = d.get("designer_bench", pure_name)
    row("the main job: 3-iteration campaign on the embedded SIL rig (its logs 6.7 s: tare, lead-in, settle, ramp-down)",
        duration(sil.seconds) if sil else d.why_not("designer_bench", sil_name),
        "the pure model simulation (the embedded rig before: 4 s logs)",
        duration(pure.seconds) if pure else d.why_not("designer_bench", pure_name),
        ratio(sil and sil.seconds, pure and pure.seconds),
        "target ratio ≤ 1.5 (#47); paper §5.2: each design optimisation ≈ 2 h CPU")
    tare_name = "BM_HysteresisFitOfRigLogs/initial_state_from_tare"
    rest_name = "BM_HysteresisFitOfRigLogs/from_rest"
    tare = d.get("designer_bench", tare_name)
    rest = d.get("designer_bench", rest_name)

    def fit(b, name):
        if not b:
            return d.why_not("designer_bench", name)
        iterations = b.counter("fit_iterations")
        if iterations is None:
            return duration(b.seconds)
        return "%s (%d iterations)" % (duration(b.seconds), iterations)
    row("the hysteresis model's fit (5 stiffnesses, force, σ) to two SIL "
        "logs back to back, each started from the Dahl forces its tare shows",
        fit(tare, tare_name),
        "the same fit with each log started from rest",
        fit(rest, rest_name),
        ratio(tare and tare.seconds, rest and rest.seconds),
        "the cost of estimating the initial state, target ≤ 1.2 (#47)")

    # diagnosis_bench
    def diagnosis(threads, half):
        name = "BM_FullDiagnosis/candidate_threads:%d/half_s:%d" % (threads, half)
        return d.get("diagnosis_bench", name), name

    def verdict_note(b, note="target ≤ 10 s for two 4 s logs"):
        if b and b.counter("correct") is not None:
            note += "; verdict %s" % ("hysteresis (right)" if b.counter("correct")
                                      else "NOT hysteresis (wrong)")
            if b.counter("right_component") is not None:
                note += ", component %s" % ("bushing:V1 (right)" if b.counter("right_component")
                                            else "NOT bushing:V1 (wrong)")
            if b.counter("high_confidence") is not None:
                note += ", confidence %s" % (
                    "high" if b.counter("high_confidence") else "low")
        return note

    (two, two_name), (one, one_name) = diagnosis(2, 2), diagnosis(1, 2)
    row("full diagnosis: two 4 s logs (2 s ramp + 2 s return, hysteresis "
        "150 N in every bushing), no hold-out: every candidate, "
        "cross-validation, localisation, drift",
        "%s on two threads" % duration(two.seconds) if two
        else d.why_not("diagnosis_bench", two_name),
        "same on one thread",
        duration(one.seconds) if one else d.why_not("diagnosis_bench", one_name),
        ratio(two and two.seconds, one and one.seconds), verdict_note(two))
    long_logs, long_name = diagnosis(2, 4)
    row("same with two 8 s logs (the paper's 4 s ramp and back)",
        "%s on two threads" % duration(long_logs.seconds) if long_logs
        else d.why_not("diagnosis_bench", long_name),
        note=verdict_note(long_logs))

    component = "BM_ComponentDiagnosisWithHoldout/candidate_threads:%d"
    two_c, one_c = (d.get("diagnosis_bench", component % k) for k in (2, 1))
    row("component-level diagnosis: two 4 s logs and one hold-out, hysteresis "
        "250 N in bushing V1 only: every component candidate",
        "%s on two threads" % duration(two_c.seconds) if two_c
        else d.why_not("diagnosis_bench", component % 2),
        "same on one thread",
        duration(one_c.seconds) if one_c else d.why_not("diagnosis_bench", component % 1),
        ratio(two_c and two_c.seconds, one_c and one_c.seconds),
        verdict_note(two_c, "target ≤ 15 s (#19)"))

    for cases, words in ((6, "six"), (20, "twenty")):
        name = "BM_ValidateOnRanks/ranks:%d/cases:" + str(cases)
        one_rank = d.get("diagnosis_bench", name % 1)
        two_ranks = d.get("diagnosis_bench", name % 2)
        row("kcrig validate, %s blind cases, under mpirun (dynamic hand-out, "
            "slow kinds first)" % words,
            "%s on 2 ranks" % duration(two_ranks.seconds) if two_ranks
            else d.why_not("diagnosis_bench", name % 2),
            "same on 1 rank",
            duration(one_rank.seconds) if one_rank
            else d.why_not("diagnosis_bench", name % 1),
            ratio(two_ranks and two_ranks.seconds,
                  one_rank and one_rank.seconds),
            "goal ≤ 0.55 (#52)")

    # rt_bench
    def percentiles(b, prefix="", tail=True):
        parts = ["p50 %s" % micros(b.counter(prefix + "p50_us")),
                 "p99 %s" % micros(b.counter(prefix + "p99_us"))]
        if tail:
            parts.append("p99.9 %s" % micros(b.counter(prefix + "p999_us")))
        return ", ".join(parts)

    cycle = d.get("rt_bench", "BM_CycleCompute")
    row("cycle compute (excitation + safety + model step), whole run profile",
        "%s (%s cycles)" % (percentiles(cycle), count(cycle.counter("count")))
        if cycle else d.why_not("rt_bench", "BM_CycleCompute"),
        note="target p99 ≤ 10 µs")
    sil_run = d.get("rt_bench", "BM_SilRigRun")
    row("the paper's first run (6.7 s) on the embedded SIL rig: loop, rig session and plant at 0.1 ms on a virtual clock",
        "%s ms CPU per second of rig time" % num(sil_run.counter("cpu_ms_per_rig_s"))
        if sil_run else d.why_not("rt_bench", "BM_SilRigRun"),
        note="target ≤ 30 ms (≥ 30× real time)")
    modbus = d.get("rt_bench", "BM_ModbusRoundTrip")
    note = "target p99 ≤ 300 µs"
    if modbus and modbus.counter("sched_fifo") == 0:
        note += "; SCHED_FIFO refused (time-sharing)"
    row("Modbus TCP read round trip to `kcrig emulate`, loopback, 1 kHz",
        "%s, %s errors (%s reads)" % (percentiles(modbus),
                                      count(modbus.counter("errors")),
                                      count(modbus.counter("count")))
        if modbus else d.why_not("rt_bench", "BM_ModbusRoundTrip"), note=note)
    wake = d.get("rt_bench", "BM_WakeupVsCyclictest")
    row("loop wake-up latency, 10 s at 1 kHz, SCHED_FIFO",
        percentiles(wake, "kcrig_", tail=False) if wake
        else d.why_not("rt_bench", "BM_WakeupVsCyclictest"),
        "cyclictest -m -i1000, same priority (rt-tests), back to back",
        "p99 %s" % micros(wake.counter("cyclictest_p99_us")) if wake
        else d.why_not("rt_bench", "BM_WakeupVsCyclictest"),
        ratio(wake.counter("kcrig_p99_us"), wake.counter("cyclictest_p99_us"))
        if wake else DASH,
        "target ratio ≤ 1.5; tails vary widely between runs on a shared VM")
    ingest = d.get("rt_bench", "BM_LiveFeedIngest")
    for arg, viewers in (("0", "three stream readers (curl)"),
                         ("1", "three headless Chromium pages"),
                         ("2", "three stream readers among 50 idle "
                               "connections, a stream never read and three "
                               "malformed requests")):
        name = "BM_ConsoleImpact/" + arg
        impact = d.get("rt_bench", name)
        note = "target ratios ≤ 1.1, no extra overrun, console CPU ≤ 5 %"
        if impact:
            note += ("; overruns %s off, %s on; console CPU %s %% of a core "
                     "(its threads) + %s %% (the feed on the logger's "
                     "thread)" % (
                         count(impact.counter("overruns_off")),
                         count(impact.counter("overruns_on")),
                         num(impact.counter("console_cpu_percent"), 2),
                         num(ingest.counter("cpu_percent_at_1khz"), 2)
                         if ingest else "?"))
        row("loop with `--console` and %s, the paper's run on `kcrig "
            "emulate` over Modbus at 1 kHz, loop pinned to CPU 1, viewers on "
            "CPU 0: compute p99, wake-up p99 (5 runs each)" % viewers,
            "%s, %s" % (micros(impact.counter("compute_p99_on_us")),
                        micros(impact.counter("wakeup_p99_on_us")))
            if impact else d.why_not("rt_bench", name),
            "the same runs without the console, in turn",
            "%s, %s" % (micros(impact.counter("compute_p99_off_us")),
                        micros(impact.counter("wakeup_p99_off_us")))
            if impact else d.why_not("rt_bench", name),
            "%s, %s" % (num(impact.counter("ratio_compute_p99")),
                        num(impact.counter("ratio_wakeup_p99")))
            if impact else DASH, note)
    codec = d.get("rt_bench", "BM_CanCycleCodec")
    row("one cycle's CAN frames through the DBC codec: KC_Command encoded + "
        "decoded, a sample's 4 frames encoded + assembled",
        duration(codec.seconds) if codec else d.why_not("rt_bench", "BM_CanCycleCodec"),
        note="target ≤ 1 µs")
    rtt = d.get("can_round_trip_vcan", "BM_CanRoundTrip")
    row("CAN round trip controller → `kcrig emulate --can vcan0` → "
        "controller, 1 kHz",
        "%s, %s timeouts (%s round trips)" % (
            percentiles(rtt, tail=False), count(rtt.counter("timeouts")),
            count(rtt.counter("count")))
        if rtt else d.why_not("can_round_trip_vcan", "BM_CanRoundTrip"),
        note="inside qemu on guest time (scripts/vcan_vm.sh: icount, a steady "
             "500 MIPS guest): not a real machine's figure")
    return out


def context_line(d):
    seen = []
    for f in FILES:
        if f not in d.docs:
            continue
        c = d.docs[f].get("context")
        if not isinstance(c, dict):
            c = {}
        fields = []
        if c.get("host_name"):
            fields.append(str(c["host_name"]))
        if c.get("num_cpus"):
            fields.append("%s CPUs" % c["num_cpus"] + (
                " at %s MHz" % c["mhz_per_cpu"] if c.get("mhz_per_cpu") else ""))
        if c.get("date"):
            fields.append(str(c["date"])[:10])
        text = ", ".join(fields) or "an unrecorded machine"
        for entry in seen:
            if entry[0] == text:
                entry[1].append(f)
                break
        else:
            seen.append((text, [f]))
    missing = [f for f in FILES if f not in d.docs]
    parts = ["%s (%s)" % (text, ", ".join(files)) for text, files in seen]
    line = "Measured on " + ("; ".join(parts) if parts else "nothing yet")
    if missing:
        line += "; not run: " + ", ".join(missing)
    return line + "."


def display_dir(directory):
    path = Path(directory).resolve()
    try:
        return str(path.relative_to(Path(__file__).resolve().parent.parent))
    except ValueError:
        return str(path)


def table(d):
    header = ("quantity", "kcrig", "peer", "peer figure", "ratio", "note")
    lines = [
        "_Generated by `scripts/bench_table.py` from `%s/*.json`. "
        % display_dir(d.directory)
        + context_line(d) + " Times are wall-clock medians over the "
        "repetitions (`scripts/bench.sh`: 5); latencies are percentiles of "
        "one run. ratio = kcrig ÷ peer (below 1: kcrig is faster or less "
        "noisy)._",
        "",
        "| " + " | ".join(header) + " |",
        "|" + "---|" * len(header),
    ]
    for r in rows(d):
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in r) + " |")
    lines += [
        "",
        "_Paper figures: Butz, Simeon, Stadler, Table 1. CPU seconds on "
        "their 3.0 GHz dual Pentium 4 PC with the DYNA4 suspension model "
        "(MATLAB/Simulink) and finite-difference gradients: another machine "
        "and another simulator, so the time ratio shows only the order of "
        "magnitude. Their criterion values are scaled differently from "
        "kcrig's and are not compared._",
    ]
    return "\n".join(lines) + "\n"


def update(path, block):
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        sys.exit("bench_table: %s: %s" % (path, e.strerror or e))
    if text.count(BEGIN) != 1 or text.count(END) != 1 or \
            text.index(BEGIN) > text.index(END):
        sys.exit("bench_table: %s: needs exactly one %s followed by one %s"
                 % (path, BEGIN, END))
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    new = head + BEGIN + "\n\n" + block + "\n" + END + tail
    directory = path.resolve().parent
    fd, temp = tempfile.mkstemp(prefix="." + path.name + ".", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write(new)
            out.flush()
            os.fsync(out.fileno())
        os.chmod(temp, path.stat().st_mode & 0o7777)
        os.replace(temp, path)
    except BaseException:
        try:
            os.unlink(temp)
        except OSError:
            pass
        raise


def main():
    parser = argparse.ArgumentParser(
        description="Markdown table of build/bench/*.json (scripts/bench.sh) "
                    "against the peers and the paper's Table 1.")
    parser.add_argument("--dir", default=str(
        Path(__file__).resolve().parent.parent / "build" / "bench"),
        help="directory of the benchmark JSON files (default: %(default)s)")
    parser.add_argument("--update", metavar="FILE",
                        help="rewrite FILE between %s and %s" % (BEGIN, END))
    args = parser.parse_args()
    block = table(Data(args.dir))
    sys.stdout.write(block)
    if args.update:
        update(args.update, block)
        print("bench_table: updated %s" % args.update, file=sys.stderr)


if __name__ == "__main__":
    main()
