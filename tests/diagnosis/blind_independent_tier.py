#!/usr/bin/python3
"""Blind diagnosis on the independent generator (tests/peers/independent_rig.py).

Usage: blind_independent_tier.py KCRIG CONFIG_DIR WORK_DIR CASES SEED [JOBS
       [KINDS]]   (KINDS: comma-separated, e.g. hard_point; default: all)

Each case draws one truth from the seed: a clean plant, an effect in a form
other than kcrig's candidates placed on one component, a wrong "known"
parameter (the spring rate, or a hard point moved in 3D), or an effect
outside every class (dry friction in the strut, free play in a link, a
stiffness drifting during the log). It draws its own designs too: two
training logs and a hold-out, each a ramp of random direction (0-90 deg),
height (0 to -0.5 m), duration (1-2.5 s), hold (0-0.3 s) and return
(0.6-1.8 s). The generator writes them with noise; the truth goes to a file
kcrig never sees.
`kcrig diagnose` judges the logs; this script compares its verdict with the
truth and prints the confusion matrix, the component and parameter hits and
the issue's figures beside their goals. `kcrig isolability` judges the same
logs: whether the diagnosis told the truth apart from every rival the
matrix calls separable, and which confusions the matrix had predicted as
ties. For an ambiguous verdict, `kcrig design --isolate` designs the ramp
for the pair; it is generated with the same truth and the case diagnosed
again with it among the training logs (resolved: the truth named alone).

It fails (exit 1) when kcrig is confidently wrong: a high-confidence verdict
naming a class that is not the truth's (for an effect outside every class:
any high-confidence class), a clean plant diagnosed as anything but `none`,
or a diagnosis that errs. The goals' rates are printed, not asserted: a CI
tier of a few cases cannot measure a 90 % rate (the full tier's are in the
notes).
"""
import concurrent.futures
import json
import math
import pathlib
import random
import subprocess
import sys

HERE = pathlib.Path(__file__).resolve().parent
GENERATOR = HERE.parent / "peers" / "independent_rig.py"
LOGS = ["train_a", "train_b", "holdout"]
BUSHINGS = ["O1", "O2", "V1", "V2", "P"]
HARD_POINTS = ["O1", "O2", "V1", "V2", "P", "N1", "N2", "U1", "U2", "Q"]
# kind -> the class kcrig should name (None: outside every class).
KINDS = {
    "clean": "none",
    "maxwell": "bushing_damping",
    "dahl_one": "hysteresis",
    "bouc_wen": "hysteresis",
    "stiffening": "progressive_stiffness",
    "actuator2": "actuator_lag",
    "fixture": "rig_compliance",
    "sensor_gain": "sensor_offset",
    "k_spring": "model_parameter",
    "hard_point": "model_parameter",
    "friction": None,
    "free_play": None,
    "drift": None,
}


def log_uniform(rng, low, high):
    return math.exp(rng.uniform(math.log(low), math.log(high)))


def draw(kind, rng):
    """Generator arguments and the truth's component for one case."""
    bushing = rng.choice(BUSHINGS)
    at = f"at=bushing:{bushing}"
    if kind == "clean":
        return [], None
    if kind == "maxwell":
        k2 = log_uniform(rng, 2e6, 2e7)
        tau = log_uniform(rng, 0.02, 0.2)
        return ["--effect", f"maxwell:{at},k2={k2:.4g},c2={k2 * tau:.4g}"], \
            f"bushing:{bushing}"
    if kind == "dahl_one":
        force = log_uniform(rng, 150, 1000)
        return ["--effect", f"dahl_one:{at},force={force:.4g}"], \
            f"bushing:{bushing}"
    if kind == "bouc_wen":
        force = log_uniform(rng, 150, 1000)
        n = rng.uniform(1.0, 2.0)
        return ["--effect", f"bouc_wen:{at},force={force:.4g},n={n:.3g}"], \
            f"bushing:{bushing}"
    if kind == "stiffening":
        c2 = log_uniform(rng, 2e10, 2e11)
        c3 = log_uniform(rng, 5e11, 5e12)
        return ["--effect", f"stiffening:{at},c2={c2:.4g},c3={c3:.4g}"], \
            f"bushing:{bushing}"
    if kind == "actuator2":
        return ["--effect",
                f"actuator2:wn={log_uniform(rng, 20, 80):.4g},"
                f"zeta={rng.uniform(0.5, 0.9):.3g},"
                f"delay={rng.uniform(0.0, 0.01):.3g}"], "actuator"
    if kind == "fixture":
        return ["--effect", f"fixture:k={log_uniform(rng, 5e6, 5e7):.4g},"
                f"k_rot={log_uniform(rng, 5e4, 5e5):.4g}"], "fixture"
    if kind == "sensor_gain":
        channel = rng.choice(["x", "y", "z", "toe", "camber", "caster"])
        gain = 1 + rng.choice([-1, 1]) * rng.uniform(0.02, 0.1)
        return ["--effect", f"sensor_gain:channel={channel},gain={gain:.4g},"
                f"coupling={rng.uniform(0.01, 0.1):.3g}"], f"sensor:{channel}"
    if kind == "k_spring":
        factor = 1 + rng.choice([-1, 1]) * rng.uniform(0.05, 0.3)
        return ["--set", f"k_spring={1.1e5 * factor:.6g}"], "k_spring"
    if kind == "hard_point":
        # A direction uniform on the sphere, 1-10 mm (log-uniform).
        point = rng.choice(HARD_POINTS)
        direction = [rng.gauss(0, 1) for _ in range(3)]
        norm = math.sqrt(sum(d * d for d in direction))
        size = log_uniform(rng, 1e-3, 1e-2)
        return ["--move-point", point,
                *[f"{size * d / norm:.6g}" for d in direction]], point
    if kind == "friction":
        return ["--effect",
                f"friction:force={log_uniform(rng, 10, 100):.4g}"], "strut"
    if kind == "free_play":
        return ["--effect", f"free_play:{at},"
                f"gap={log_uniform(rng, 3e-5, 3e-4):.4g}"], \
            f"bushing:{bushing}"
    if kind == "drift":
        return ["--effect", "drift:fraction="
                f"{rng.choice([-1, 1]) * rng.uniform(0.05, 0.2):.3g}"], None
    raise ValueError(kind)


def draw_design(rng):
    """One ramp: direction, height, duration, hold and return."""
    return ["--phi", f"{rng.uniform(0, 90):.4g}",
            "--z", f"{rng.uniform(-0.5, 0):.4g}",
            "--duration", f"{rng.uniform(1, 2.5):.4g}",
            "--hold", f"{rng.uniform(0, 0.3):.4g}",
            "--return", f"{rng.uniform(0.6, 1.8):.4g}"]


def configured_point(config, point):
    """The configured coordinates of a hard point [m]."""
    import yaml
    doc = yaml.safe_load((config / "model.yaml").read_text())
    if point in BUSHINGS:
        return doc["bushings"][point]["chassis"]
    carrier = dict(zip(["N1", "N2", "U1", "U2", "Q"], BUSHINGS))
    return doc["bushings"][carrier[point]]["carrier"]


def point_assignments(config, point, move):
    """--set NAME=VALUE for each coordinate of a moved point."""
    arguments = []
    for axis, value, offset in zip("xyz", configured_point(config, point),
                                   move):
        arguments += ["--set", f"{point}.{axis}={value + float(offset):.6g}"]
    return arguments


def run(command):
    result = subprocess.run(command, capture_output=True, text=True)
    return result.returncode, result.stdout, result.stderr


def run_case(index, kind, arguments, designs, kcrig, config, work):
    case = work / f"case_{index:03d}"
    case.mkdir(parents=True, exist_ok=True)
    move = None
    if arguments[:1] == ["--move-point"]:
        point, move = arguments[1], [float(d) for d in arguments[2:5]]
        arguments = point_assignments(config, arguments[1], move)
    logs = {}
    for seed_offset, (name, design) in enumerate(zip(LOGS, designs)):
        path = case / f"{name}.csv"
        command = ["/usr/bin/python3", str(GENERATOR), "--config",
                   str(config), *design, *arguments,
                   "--noise", "--seed", str(1000 * index + seed_offset),
                   "--out", str(path)]
        if name == "holdout":
            command += ["--truth", str(case / "truth.json")]
        else:
            command += ["--noise-free-copy", str(case / f"{name}_clean.csv")]
        code, _, error = run(command)
        if code != 0:
            return {"index": index, "kind": kind, "error": error.strip()}
        logs[name] = path
    code, _, error = run([kcrig, "diagnose", "--config", str(config),
                          "--log", str(logs["train_a"]), "--log",
                          str(logs["train_b"]), "--holdout",
                          str(logs["holdout"]), "--quiet", "--out",
                          str(case / "diag.json")])
    if code != 0:
        return {"index": index, "kind": kind, "error": error.strip()}
    diag = json.loads((case / "diag.json").read_text())
    code, _, error = run([kcrig, "isolability", "--config", str(config),
                          *[a for name in LOGS for a in ("--log",
                                                         str(logs[name]))],
                          "--quiet", "--out", str(case / "iso.json")])
    # A matrix that cannot be computed is a finding of its own, not a
    # failed diagnosis.
    iso = ({"error": error.strip()} if code != 0 else
           json.loads((case / "iso.json").read_text()))
    size = effect_size(kcrig, config, case)
    if size is None:
        return {"index": index, "kind": kind, "error": "size: estimate failed"}
    closed = (diag.get("quantification") or {}).get("gap_closed")
    leaves_noise = (diag.get("quantification") or {}).get("leaves_noise",
                                                           False)
    return {"index": index, "kind": kind, "arguments": arguments,
            "designs": designs,
            "truth_in_interval": (point_in_region(point, move, diag) if move
                                  else truth_in_interval(arguments, diag)),
            "stiffness_errors": stiffness_errors(config, diag),
            "size_sigma": size, "verdict": diag["verdict"],
            "model": diag.get("model", ""), "confidence": diag["confidence"],
            "components": diag.get("components", []), "gap_closed": closed,
            "leaves_noise": leaves_noise,
            "reason": diag.get("reason", ""),
            "ambiguous": diag.get("ambiguous") or [],
            "discrepancy": diag.get("discrepancy"),
            "isolability": iso,
            "isolating": isolate_tie(index, arguments, diag, logs, kcrig,
                                     config, case)}


def isolate_tie(index, arguments, diag, logs, kcrig, config, case):
    """For an ambiguous verdict: `kcrig design --isolate` on the pair, the
    ramp it proposes generated with the same truth, and the diagnosis
    again with it among the training logs. None without an ambiguous pair
    of single candidates."""
    pair = diag.get("ambiguous") or []
    if len(pair) != 2 or any("+" in name for name in pair):
        return None
    code, _, error = run([kcrig, "design", "--isolate", "--config",
                          str(config),
                          *[a for name in LOGS for a in ("--log",
                                                         str(logs[name]))],
                          "--candidates", ",".join(pair), "--quiet",
                          "--out", str(case / "isolating.json")])
    if code != 0:
        return {"pair": pair, "error": error.strip()}
    design = json.loads((case / "isolating.json").read_text())
    if not design["ties"]:
        return {"pair": pair, "tied_by_matrix": False}
    ramp = design["run_options"].split()
    path = case / "isolating.csv"
    code, _, error = run(["/usr/bin/python3", str(GENERATOR), "--config",
                          str(config), *ramp, *arguments, "--noise",
                          "--seed", str(1000 * index + 7), "--out",
                          str(path)])
    if code != 0:
        return {"pair": pair, "error": error.strip()}
    code, _, error = run([kcrig, "diagnose", "--config", str(config),
                          "--log", str(logs["train_a"]), "--log",
                          str(logs["train_b"]), "--log", str(path),
                          "--holdout", str(logs["holdout"]), "--quiet",
                          "--out", str(case / "diag_isolated.json")])
    if code != 0:
        return {"pair": pair, "error": error.strip()}
    after = json.loads((case / "diag_isolated.json").read_text())
    return {"pair": pair, "tied_by_matrix": True,
            "predicted_resolved": design["resolved"] > 0,
            "separation_after": design["smallest_separation_after"],
            "model_after": after.get("model", ""),
            "ambiguous_after": after.get("ambiguous") or []}


def truth_in_interval(arguments, diag):
    """For a wrong "known" parameter (--set NAME=VALUE) that the verdict's
    model frees: whether the true value lies in its 95 % interval; None
    otherwise."""
    if arguments[:1] != ["--set"]:
        return None
    name, value = arguments[1].split("=")
    for candidate in diag.get("candidates", []):
        if candidate["model"] != diag.get("model"):
            continue
        for p in candidate["parameters"]:
            if p["name"] == f"model_parameter.{name}":
                low, high = p["ci95"]
                return low <= float(value) <= high
    return None


def point_in_region(point, move, diag):
    """For a moved hard point that the verdict's model moves: whether the
    true move lies in the 95 % region of the fitted one; None otherwise."""
    for fitted in (diag.get("quantification") or {}).get("hard_points", []):
        if fitted["point"] != point:
            continue
        covariance = fitted["covariance_m2"]
        if covariance is None:
            return None
        d = [t - f for t, f in zip(move, fitted["displacement_m"])]
        return mahalanobis2(covariance, d) <= fitted["region_chi2_95"]
    return None


def mahalanobis2(c, d):
    """d^T C^-1 d for a 3x3 covariance (Cramer's rule)."""
    def det(m):
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    whole = det(c)
    if not whole > 0:
        return math.inf
    x = []
    for k in range(3):
        replaced = [[d[i] if j == k else c[i][j] for j in range(3)]
                    for i in range(3)]
        x.append(det(replaced) / whole)
    return sum(a * b for a, b in zip(d, x))


def stiffness_errors(config, diag):
    """Per bushing stiffness of the verdict's model: its error in
    half-widths of its 95 % interval (|e| <= 1: the interval covers the
    rig's stiffness, the configured one: the generator never changes it)."""
    import yaml
    doc = yaml.safe_load((config / "model.yaml").read_text())
    errors = {}
    for candidate in diag.get("candidates", []):
        if candidate["model"] != diag.get("model"):
            continue
        for p in candidate["parameters"]:
            bushing = p["name"][2:] if p["name"].startswith("c_") else None
            low, high = p["ci95"]
            if bushing not in BUSHINGS or low is None or high is None:
                continue
            truth = float(doc["bushings"][bushing]["stiffness"])
            errors[p["name"]] = (truth - (low + high) / 2) / ((high - low) / 2)
    return errors


def effect_size(kcrig, config, case):
    """The size of the effect "in the residual", as the other blind tiers
    define it: sigma_hat (RMS in noise units) of the nominal fit, bushings
    fitted, on the training logs without noise."""
    code, _, _ = run([kcrig, "estimate", "--config", str(config), "--log",
                      str(case / "train_a_clean.csv"), "--log",
                      str(case / "train_b_clean.csv"), "--out",
                      str(case / "size_est.json")])
    if code != 0:
        return None
    return json.loads((case / "size_est.json").read_text())["sigma_hat"]


def verdict_class(result):
    verdict = result["verdict"]
    if verdict in ("none", "unexplained"):
        return verdict
    return "pair" if "+" in verdict else verdict


def confidently_wrong(result):
    expected = KINDS[result["kind"]]
    got = verdict_class(result)
    if result["kind"] == "clean":
        return got != "none"
    if result["confidence"] != "high" or got in ("none", "unexplained"):
        return False
    return expected is None or got != expected


def component_hit(result, component):
    """Whether the verdict names the truth's component: the freed parameter;
    the bushing or the sensor channel, alone; for the actuators (every axis
    in the truth) their axes only; for a fixture that gives and turns, its
    axes only, a rotation among them (axes the designs do not load may be
    left out)."""
    if component is None:
        return None
    if result["kind"] in ("k_spring", "hard_point"):
        return f"model_parameter@{component}" in result["model"].split("+")
    named = result["components"]
    if component == "actuator":
        return bool(named) and all(c.startswith("actuator:") for c in named)
    if component == "fixture":
        return (bool(named) and all(c.startswith("fixture:") for c in named)
                and any(c in ("fixture:rx", "fixture:ry") for c in named))
    return named == [component]


# kind -> the matrix's candidate for a truth on one component.
MATRIX_CLASS = {"maxwell": "bushing_damping", "dahl_one": "hysteresis",
                "bouc_wen": "hysteresis", "stiffening": "progressive_stiffness",
                "sensor_gain": "sensor_offset", "k_spring": "model_parameter",
                "hard_point": "model_parameter"}


def matrix_candidate(kind, component):
    """The truth as `kcrig isolability` names it (None: the truth acts on
    more than one component, or on none, and is no candidate)."""
    if kind not in MATRIX_CLASS or component is None:
        return None
    return f"{MATRIX_CLASS[kind]}@{component}"


def isolability_outcome(result, component):
    """For a truth on one component that the logs show: the rivals the
    matrix calls separable from it and those it calls tied, the rivals the
    diagnosis confused with it (named instead of it, or left ambiguous with
    it) and whether it decided at all (a verdict of `none`, or `unexplained`
    without an ambiguous pair, tells nothing apart and confuses nothing);
    None when the truth is no candidate of the matrix or not seen."""
    truth = matrix_candidate(result["kind"], component)
    iso = result["isolability"]
    if "error" in iso or truth not in iso["candidates"]:
        return None
    i = iso["candidates"].index(truth)
    if not iso["visible"][i]:
        return None
    threshold = iso["min_share_left"]
    separable, tied = set(), set()
    for j, name in enumerate(iso["candidates"]):
        if j == i or not iso["visible"][j]:
            continue
        a, b = iso["left"][i][j], iso["left"][j][i]
        (separable if min(a, b) >= threshold else tied).add(name)
    named = set(result["ambiguous"]) | {result["model"]}
    return {"truth": truth, "separable": separable, "tied": tied,
            "confused": {n for n in named if n and n != truth},
            "decided": bool(result["model"]) or bool(result["ambiguous"])}


def resolved(result, component):
    """Whether the diagnosis with the isolating ramp named the truth alone;
    None when no isolating ramp ran on a tie the truth is part of."""
    i = result.get("isolating")
    truth = matrix_candidate(result["kind"], component)
    if not i or "error" in i or not i.get("tied_by_matrix") or \
            truth not in i["pair"]:
        return None
    return i["model_after"] == truth and not i["ambiguous_after"]


def rate(hits, goal):
    n = len(hits)
    if n == 0:
        return "no cases"
    value = sum(hits) / n
    return (f"{sum(hits)}/{n} = {100 * value:.0f} % (goal {100 * goal:.0f} "
            f"%: {'met' if value >= goal else 'missed'})")


def summarise(results, components):
    classes = ["none", "bushing_damping", "hysteresis",
               "progressive_stiffness", "actuator_lag", "rig_compliance",
               "sensor_offset", "model_parameter", "pair", "unexplained"]
    print("class confusion (rows: truth; columns: verdict)")
    print(" " * 22 + " ".join(f"{c[:6]:>6s}" for c in classes))
    for kind in KINDS:
        rows = [r for r in results if r["kind"] == kind and "error" not in r]
        if not rows:
            continue
        counts = [sum(verdict_class(r) == c for r in rows) for c in classes]
        print(f"{kind:>22s}" + " ".join(f"{n:6d}" for n in counts))
    large = [r for r in results if "error" not in r and
             KINDS[r["kind"]] not in (None, "none") and r["size_sigma"] >= 3]
    print("effects >= 3x noise, right class: " +
          rate([verdict_class(r) == KINDS[r["kind"]] for r in large], 0.9))
    placed = [r for r in large if components[r["index"]] is not None and
              r["kind"] not in ("k_spring", "hard_point")]
    print("effects >= 3x noise, right component: " +
          rate([bool(component_hit(r, components[r["index"]]))
                for r in placed], 0.8))
    bushing_placed = [r for r in placed
                      if str(components[r["index"]]).startswith("bushing:")]
    print("  of those in one bushing: " +
          rate([bool(component_hit(r, components[r["index"]]))
                for r in bushing_placed], 0.8))
    wrong_parameter = [r for r in large
                       if r["kind"] in ("k_spring", "hard_point")]
    print("wrong parameters >= 3x noise, right parameter named: " +
          rate([bool(component_hit(r, components[r["index"]]))
                for r in wrong_parameter], 0.8))
    named = [r for r in wrong_parameter
             if component_hit(r, components[r["index"]])]
    print("  named, the true value in its 95 % interval (a point's move "
          "in its 3D region): " +
          rate([bool(r.get("truth_in_interval")) for r in named], 0.9))
    points = [r for r in large if r["kind"] == "hard_point"]
    print("  hard points >= 3x noise named: " +
          rate([bool(component_hit(r, components[r["index"]]))
                for r in points], 0.8) + "; in the 3D region: " +
          rate([bool(r.get("truth_in_interval")) for r in points
                if component_hit(r, components[r["index"]])], 0.9))
    print("  hard points >= 3x noise named or one of an ambiguous pair "
          "(most often the other end of its link): " +
          rate([bool(component_hit(r, components[r["index"]])) or
                f"model_parameter@{components[r['index']]}" in
                r.get("ambiguous", []) for r in points], 0.8))
    detected = [r for r in results if "error" not in r and
                KINDS[r["kind"]] not in (None, "none") and
                r["verdict"] != "none"]
    for label, group in (("effects >= 3x noise", large),
                         ("every size with a gap found", detected)):
        outcomes = [o for o in (isolability_outcome(r, components[r["index"]])
                                for r in group) if o is not None]
        decided = [o for o in outcomes if o["decided"]]
        print(f"isolability ({label}, on one component, seen): cases that "
              "told the truth apart from every rival the matrix calls "
              "separable: " +
              rate([not (o["confused"] & o["separable"]) for o in decided],
                   0.95) + f" ({len(outcomes) - len(decided)} more ended "
              "none or unexplained without a pair)")
        confusions = [(o, rival) for o in outcomes for rival in o["confused"]]
        in_matrix = [(o, rival) for o, rival in confusions
                     if rival in o["separable"] | o["tied"]]
        print(f"  confusions: {len(confusions)}, {len(in_matrix)} with a "
              "candidate of the matrix, of which it predicted as ties: " +
              rate([rival in o["tied"] for o, rival in in_matrix], 0.95))
        for o, rival in confusions:
            print(f"    {o['truth']} confused with {rival}" +
                  ("" if rival in o["separable"] | o["tied"] else
                   " (not a candidate of the matrix)") +
                  (" (predicted)" if rival in o["tied"] else ""))
    isolating = [r for r in results
                 if "error" not in r and r.get("isolating")]
    for r in isolating:
        i = r["isolating"]
        truth = matrix_candidate(r["kind"], components[r["index"]])
        if "error" in i:
            print(f"  case {r['index']}: design --isolate failed: "
                  f"{i['error']}")
            continue
        after = (f"verdict after: {i['model_after'] or 'none'}" +
                 (" ~ " + " ~ ".join(i["ambiguous_after"])
                  if i["ambiguous_after"] else "")
                 if i.get("tied_by_matrix") else "not a tie of the matrix")
        print(f"  case {r['index']} (truth {truth}): tie "
              f"{' ~ '.join(i['pair'])}; " +
              (f"the isolating ramp's separation "
               f"{100 * i['separation_after']:.0f} %, "
               if i.get("tied_by_matrix") else "") + after)
    outcomes = [(r, resolved(r, components[r["index"]])) for r in isolating]
    outcomes = [(r, ok) for r, ok in outcomes if ok is not None]
    print("ties the matrix predicted (the truth one of the pair), resolved "
          "by the ramp kcrig design --isolate proposes: " +
          rate([ok for _, ok in outcomes], 0.9))
    print("  of those it predicted resolvable: " +
          rate([ok for r, ok in outcomes
                if r["isolating"]["predicted_resolved"]], 0.9))
    failed = [r["index"] for r in results
              if "error" not in r and "error" in r["isolability"]]
    if failed:
        print(f"  kcrig isolability failed on cases {failed}")
    clean = [r for r in results if r["kind"] == "clean" and "error" not in r]
    print("clean: none " + rate([r["verdict"] == "none" for r in clean],
                                0.95))
    outside = [r for r in results if "error" not in r and
               KINDS[r["kind"]] is None]
    print("outside every class: no high-confidence class " +
          rate([not confidently_wrong(r) for r in outside], 1.0))
    characterised = outside
    print("outside every class: the discrepancy closes >= 50 % "
          "of the held-out gap " +
          rate([bool(r["discrepancy"]) and
                (r["discrepancy"]["gap_closed"] or 0) >= 0.5
                for r in characterised], 0.7))
    for r in characterised:
        d = r["discrepancy"]
        print(f"  case {r['index']} ({r['kind']}): " +
              (d["text"] if d else "not characterised"))
    correct = [r for r in results if "error" not in r and
               KINDS[r["kind"]] not in (None, "none") and
               verdict_class(r) == KINDS[r["kind"]]]
    print("correct verdicts closing >= 80 % of the held-out gap or leaving "
          "only noise: " +
          rate([(r["gap_closed"] or 0) >= 0.8 or r["leaves_noise"]
                for r in correct], 1.0))
    errors = [e for r in correct for e in r["stiffness_errors"].values()]
    print("correct verdicts: stiffness 95 % intervals covering the rig's "
          "(goal 90-98 %): " + rate([abs(e) <= 1 for e in errors], 0.9) +
          (f"; largest error {max(abs(e) for e in errors):.1f} half-widths"
           if errors else ""))
    large_correct = [r for r in large if verdict_class(r) == KINDS[r["kind"]]]
    print("correct verdicts on effects >= 3x noise with high confidence: " +
          rate([r["confidence"] == "high" for r in large_correct], 0.7))
    high = [r for r in results if "error" not in r and
            r["confidence"] == "high" and r["kind"] != "clean"]
    print("high confidence right: " +
          rate([verdict_class(r) == KINDS[r["kind"]] for r in high], 0.97))


def main():
    kcrig, config, work = sys.argv[1], pathlib.Path(sys.argv[2]), \
        pathlib.Path(sys.argv[3])
    cases, seed = int(sys.argv[4]), int(sys.argv[5])
    jobs = int(sys.argv[6]) if len(sys.argv) > 6 else 2
    rng = random.Random(seed)
    kinds = sys.argv[7].split(",") if len(sys.argv) > 7 else list(KINDS)
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        sys.exit(f"blind_independent_tier: unknown kinds {unknown}; "
                 f"known: {', '.join(KINDS)}")
    draws = []
    for index in range(cases):
        kind = kinds[index % len(kinds)]
        designs = [draw_design(rng) for _ in LOGS]
        draws.append((index, kind, *draw(kind, rng), designs))
    components = {index: component for index, _, _, component, _ in draws}
    with concurrent.futures.ThreadPoolExecutor(jobs) as pool:
        futures = [pool.submit(run_case, index, kind, arguments, designs,
                               kcrig, config, work)
                   for index, kind, arguments, _, designs in draws]
        results = [f.result() for f in futures]
    (work / "results.json").write_text(json.dumps(results, indent=2) + "\n")
    print("case kind size/sigma verdict confidence components closed")
    for r in results:
        if "error" in r:
            print(f"{r['index']:3d} {r['kind']:>12s} ERROR {r['error']}")
            continue
        closed = r["gap_closed"]
        print(f"{r['index']:3d} {r['kind']:>12s} {r['size_sigma']:7.2f} "
              f"{r['model'] or r['verdict']:40s} {r['confidence']:6s} "
              f"{','.join(r['components']):24s} "
              + (f"{100 * closed:.0f} %" if closed is not None else "-")
              + f"  [truth {components[r['index']]}]")
    summarise(results, components)
    failures = [r for r in results if "error" in r or confidently_wrong(r)]
    if failures:
        sys.exit("FAIL: confidently wrong or failed on cases " +
                 ", ".join(str(r["index"]) for r in failures))
    print("PASS: no confident wrong answer")


if __name__ == "__main__":
    main()
