#!/usr/bin/python3
"""An independent K&C rig: the blind tiers' second data generator.

The same five-link suspension as kcrig's model (config/model.yaml), written
from the physics without kcrig's code, in another formulation and with
another integrator:
  - the carrier's attitude is a unit quaternion (kcrig: Cardan angles), its
    velocity the rig-frame velocity of the wheel centre and the body-frame
    angular velocity, Newton-Euler about the wheel centre;
  - each link and the strut is an axial element between its chassis and
    carrier point, free length at the design position, force
    k (l - l0) + d dl/dt along the link (positive in tension);
  - SciPy's adaptive Runge-Kutta (DOP853, rtol 1e-8) integrates it phase by
    phase of the ramp (kcrig: semi-implicit Euler at a fixed step);
  - the start is the static equilibrium under the first sample's force
    (scipy.optimize.root), the outputs the wheel centre and the Cardan
    angles toe, camber, caster of R = Rz(toe) Rx(camber) Ry(caster).

It writes a kcrig run log (run.csv + run.json sidecar, the documented
format), so that kcrig analyses its logs as a rig's. The truth (parameters
set, effects with their components) goes to a separate file only
(--truth), never into the sidecar; --noise-free-copy writes the same run
without noise (what the blind tiers measure an effect's size on).

Effects (--effect KIND:key=value,...; `at` names the component), in forms
that differ from kcrig's candidates on purpose:
  maxwell      standard-linear-solid rubber in one bushing: a spring k2 in
               series with a damper c2 beside the link (at=bushing:X, k2, c2)
  bouc_wen     Bouc-Wen hysteresis in one bushing (at, force, sigma, n)
  stiffening   asymmetric progressive stiffness in one bushing: extra
               force c2 d^2 for d > 0 and c3 d^3 (at, c2, c3)
  actuator2    second-order actuator dynamics with a delay between the
               load cell and the wheel (wn [rad/s], zeta, delay [s])
  fixture      fixture compliance: the measured wheel centre moves by F/k
               per axis and the angles by M/k_rot (k, k_rot)
  sensor_gain  one channel's gain and a cross-axis coupling
               (channel, gain, coupling: into the next channel)
  friction     dry friction in the strut: Ff tanh(dl/dt / v0) (force, v0)
  free_play    free play in one link: no force within +-gap (at, gap)
  drift        every bushing's stiffness drifts linearly with time during
               the log, by `fraction` over the log (temperature)
  dahl_one     Dahl hysteresis in one bushing (at, force, sigma)
Wrong "known" parameters: --set NAME=VALUE with kcrig's names (k_spring,
d_damper, mass, Jxx, c_O1, d_V1, O1.z, N1.x, spring_chassis.y, ...).
"""
import argparse
import json
import math
import pathlib
import sys

import numpy as np
import yaml
from scipy.integrate import solve_ivp
from scipy.optimize import root

BUSHINGS = ["O1", "O2", "V1", "V2", "P"]
CARRIER_POINTS = {"O1": "N1", "O2": "N2", "V1": "U1", "V2": "U2", "P": "Q"}
CHANNELS = ["x", "y", "z", "toe", "camber", "caster"]


class Model:
    """Masses and elements: rows 0-4 the bushings, row 5 the strut."""

    def __init__(self, config):
        doc = yaml.safe_load((config / "model.yaml").read_text())
        self.mass = float(doc["mass"])
        self.inertia = np.array(doc["inertia"], dtype=float)
        elements = [doc["bushings"][b] for b in BUSHINGS] + [doc["spring"]]
        self.chassis = np.array([e["chassis"] for e in elements], dtype=float)
        self.carrier = np.array([e["carrier"] for e in elements], dtype=float)
        self.stiffness = np.array([e["stiffness"] for e in elements], float)
        self.damping = np.array([e["damping"] for e in elements], float)

    def set(self, assignment):
        name, _, value = assignment.partition("=")
        value = float(value)
        if name.startswith("c_") and name[2:] in BUSHINGS:
            self.stiffness[BUSHINGS.index(name[2:])] = value
        elif name.startswith("d_") and name[2:] in BUSHINGS:
            self.damping[BUSHINGS.index(name[2:])] = value
        elif name == "k_spring":
            self.stiffness[5] = value
        elif name == "d_damper":
            self.damping[5] = value
        elif name == "mass":
            self.mass = value
        elif name in ("Jxx", "Jyy", "Jzz"):
            self.inertia["xyz".index(name[1])] = value
        elif "." in name:
            point, axis = name.split(".")
            k = "xyz".index(axis)
            if point in BUSHINGS:
                self.chassis[BUSHINGS.index(point), k] = value
            elif point in CARRIER_POINTS.values():
                row = list(CARRIER_POINTS.values()).index(point)
                self.carrier[row, k] = value
            elif point == "spring_chassis":
                self.chassis[5, k] = value
            elif point == "spring_carrier":
                self.carrier[5, k] = value
            else:
                raise ValueError(f"--set {assignment}: unknown point")
        else:
            raise ValueError(f"--set {assignment}: unknown parameter")

    def free_lengths(self):
        return np.linalg.norm(self.chassis - self.carrier, axis=1)


def quaternion_matrix(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def rotation_vector_quaternion(v):
    angle = np.linalg.norm(v)
    if angle < 1e-300:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[math.cos(angle / 2)],
                           math.sin(angle / 2) * v / angle])


def cardan_angles(rotation):
    """toe, camber, caster of R = Rz(toe) Rx(camber) Ry(caster)."""
    camber = math.asin(max(-1.0, min(1.0, rotation[2, 1])))
    toe = math.atan2(-rotation[0, 1], rotation[1, 1])
    caster = math.atan2(-rotation[2, 0], rotation[2, 2])
    return toe, camber, caster


class Ramp:
    """The paper's ramp -Fmax -> +Fmax over tf, hold, return ramp."""

    def __init__(self, phi, z_a, fmax, duration, hold, return_duration):
        self.phi, self.z_a, self.fmax = phi, z_a, fmax
        self.duration, self.hold = duration, hold
        self.return_duration = return_duration

    def end(self):
        return self.duration + self.hold + self.return_duration

    def breaks(self):
        turn = self.duration + self.hold
        return sorted({0.0, self.duration, turn, self.end()})

    def level(self, t):
        turn = self.duration + self.hold
        if self.return_duration > 0 and t > turn:
            return max(1 - 2 * (t - turn) / self.return_duration, -1.0)
        return min(max((2 * t - self.duration) / self.duration, -1.0), 1.0)

    def force(self, t):
        f = self.fmax * self.level(t)
        return np.array([f * math.cos(self.phi), f * math.sin(self.phi), 0.0])


class Plant:
    """State: r (3), q (4), v (3), omega (3), then the effects' states."""

    def __init__(self, model, effects, ramp):
        self.m = model
        self.effects = effects
        self.ramp = ramp
        self.l0 = model.free_lengths()
        self.point = np.array([0.0, 0.0, ramp.z_a])
        self.extra_states = 0
        for e in effects:
            e["state"] = self.extra_states
            self.extra_states += {"maxwell": 1, "bouc_wen": 1, "dahl_one": 1,
                                  "actuator2": 6}.get(e["kind"], 0)

    def element_forces(self, t, l, ldot, s):
        """Axial forces of the six elements and the effect states' rates."""
        m = self.m
        k = m.stiffness.copy()
        for e in self.effects:
            if e["kind"] == "drift":
                k[:5] *= 1 + e["fraction"] * t / self.ramp.end()
        deflection = l - self.l0
        elastic = k * deflection
        rates = np.zeros(self.extra_states)
        for e in self.effects:
            i = e.get("row")
            kind = e["kind"]
            if kind == "free_play":
                g = e["gap"]
                elastic[i] = k[i] * (deflection[i] -
                                     np.clip(deflection[i], -g, g))
            elif kind == "stiffening":
                d = deflection[i]
                elastic[i] += e["c3"] * d**3 + (e["c2"] * d * d if d > 0
                                                else 0.0)
        force = elastic + m.damping * ldot
        for e in self.effects:
            i, j, kind = e.get("row"), e["state"], e["kind"]
            if kind == "maxwell":
                # The series spring's stretch is l - l0 - x_d; the damper
                # moves at the spring force over c2.
                spring = e["k2"] * (l[i] - self.l0[i] - s[j])
                force[i] += spring
                rates[j] = spring / e["c2"]
            elif kind == "bouc_wen":
                # Normalised Bouc-Wen, beta = gamma = 1/2: z saturates at 1
                # on loading and leaves the saturation at the rest slope.
                z = s[j]
                loading = 0.5 + 0.5 * np.sign(ldot[i] * z)
                rates[j] = e["sigma"] / e["force"] * ldot[i] * (
                    1 - loading * abs(z)**e["n"])
                force[i] += e["force"] * z
            elif kind == "dahl_one":
                h = s[j]
                rates[j] = e["sigma"] * ldot[i] * (
                    1 - h / e["force"] * np.sign(ldot[i]))
                force[i] += h
            elif kind == "friction":
                force[5] += e["force"] * math.tanh(ldot[5] / e["v0"])
        return force, rates

    def wheel_force(self, t, s):
        for e in self.effects:
            if e["kind"] == "actuator2":
                j = e["state"]
                return s[j:j + 3]
        return self.ramp.force(t)

    def actuator_rates(self, t, s, rates):
        for e in self.effects:
            if e["kind"] != "actuator2":
                continue
            j = e["state"]
            wn, zeta = e["wn"], e["zeta"]
            target = self.ramp.force(max(t - e["delay"], 0.0))
            position, velocity = s[j:j + 3], s[j + 3:j + 6]
            rates[j:j + 3] = velocity
            rates[j + 3:j + 6] = (wn * wn * (target - position) -
                                  2 * zeta * wn * velocity)

    def generalized(self, t, x):
        """Rig-frame force and body-frame moment on the carrier, effect
        states' rates, and the rotation."""
        r, q, v, omega = x[0:3], x[3:7], x[7:10], x[10:13]
        s = x[13:]
        rotation = quaternion_matrix(q)
        b = self.m.carrier
        lever = b @ rotation.T
        d = self.m.chassis - r - lever
        l = np.linalg.norm(d, axis=1)
        u = d / l[:, None]
        point_velocity = v + np.cross(omega, b) @ rotation.T
        ldot = -np.einsum("ij,ij->i", u, point_velocity)
        axial, rates = self.element_forces(t, l, ldot, s)
        forces = axial[:, None] * u
        load = self.wheel_force(t, s)
        force = forces.sum(axis=0) + load
        moment = (np.cross(b, forces @ rotation).sum(axis=0) +
                  np.cross(self.point, rotation.T @ load))
        self.actuator_rates(t, s, rates)
        return force, moment, rates, rotation

    def rate(self, t, x):
        force, moment, rates, _ = self.generalized(t, x)
        q, v, omega = x[3:7], x[7:10], x[10:13]
        w, qx, qy, qz = q
        ox, oy, oz = omega
        q_rate = 0.5 * np.array([-qx * ox - qy * oy - qz * oz,
                                 w * ox + qy * oz - qz * oy,
                                 w * oy - qx * oz + qz * ox,
                                 w * oz + qx * oy - qy * ox])
        j = self.m.inertia
        omega_rate = (moment - np.cross(omega, j * omega)) / j
        return np.concatenate([v, q_rate, force / self.m.mass, omega_rate,
                               rates])

    def initial_state(self):
        """Static equilibrium under the first force, effects settled."""
        s0 = np.zeros(self.extra_states)
        for e in self.effects:
            if e["kind"] == "actuator2":
                s0[e["state"]:e["state"] + 3] = self.ramp.force(0.0)

        def state(unknowns):
            x = np.zeros(13 + self.extra_states)
            x[0:3] = unknowns[0:3]
            x[3:7] = rotation_vector_quaternion(unknowns[3:6])
            x[13:] = s0
            x[13:] = self.settled_states(x)
            return x

        def residual(unknowns):
            force, moment, _, _ = self.generalized(0.0, state(unknowns))
            return np.concatenate([force / 1e3, moment / 1e2])

        # Powell's hybrid method, polished by Levenberg-Marquardt where it
        # stalls at the last digits (a kink of a hysteresis branch); judged
        # by the residual itself (1e-6 N, 1e-6 N m).
        guess = root(residual, np.zeros(6), method="hybr", tol=1e-14).x
        solution = root(residual, guess, method="lm", tol=1e-14)
        if not np.abs(residual(solution.x)).max() < 1e-8:
            raise RuntimeError("no static equilibrium: " + solution.message)
        return state(solution.x)

    def settled_states(self, x):
        """Hysteresis on its loading branch from the design position, the
        Maxwell damper relaxed: the state after the rig's lead-in."""
        s = x[13:].copy()
        rotation = quaternion_matrix(x[3:7])
        d = self.m.chassis - x[0:3] - self.m.carrier @ rotation.T
        deflection = np.linalg.norm(d, axis=1) - self.l0
        for e in self.effects:
            i, j = e.get("row"), e["state"]
            if e["kind"] == "maxwell":
                s[j] = deflection[i]
            elif e["kind"] == "dahl_one":
                s[j] = e["force"] * math.copysign(
                    -math.expm1(-e["sigma"] * abs(deflection[i]) / e["force"]),
                    deflection[i])
            elif e["kind"] == "bouc_wen":
                s[j] = math.copysign(
                    -math.expm1(-e["sigma"] * abs(deflection[i]) / e["force"]),
                    deflection[i])
        return s

    def measured(self, t, x):
        force, moment, _, rotation = self.generalized(t, x)
        y = np.concatenate([x[0:3], cardan_angles(rotation)])
        for e in self.effects:
            if e["kind"] == "fixture":
                # The clamped body gives under the reaction of the links:
                # it turns by the rotation vector M / k_rot, which moves
                # camber (about x), caster (about y) and toe (about z).
                y[0:3] += self.ramp.force(t) / e["k"]
                turn = np.cross(self.point, self.ramp.force(t)) / e["k_rot"]
                y[3:6] += turn[[2, 0, 1]]
        return y


def simulate(plant, rate):
    """Outputs at t = j / rate over the ramp, phase by phase."""
    x = plant.initial_state()
    end = plant.ramp.end()
    samples = int(math.floor(end * rate + 1e-9)) + 1
    times = np.arange(samples) / rate
    outputs = np.zeros((samples, 6))
    breaks = plant.ramp.breaks()
    for effect in plant.effects:
        if effect["kind"] == "actuator2" and effect["delay"] > 0:
            breaks = sorted(set(breaks) | {b + effect["delay"]
                                          for b in breaks if
                                          b + effect["delay"] < end})
    for start, stop in zip(breaks[:-1], breaks[1:]):
        inside = (times >= start - 1e-12) & (times <= stop + 1e-12)
        wanted = np.unique(np.clip(np.append(times[inside], stop), start,
                                   stop))
        solution = solve_ivp(plant.rate, (start, stop), x, method="DOP853",
                             t_eval=wanted, rtol=1e-8, atol=1e-11,
                             max_step=1e-2)
        if not solution.success:
            raise RuntimeError(solution.message)
        for k, t in enumerate(solution.t):
            index = int(round(t * rate))
            if abs(index - t * rate) < 1e-6 and index < samples:
                outputs[index] = plant.measured(t, solution.y[:, k])
        x = solution.y[:, -1]
    return times, outputs


def sensors(outputs, config, noise, seed, effects):
    experiment = yaml.safe_load((config / "experiment.yaml").read_text())
    plant = yaml.safe_load((config / "plant.yaml").read_text())
    measurement = experiment["measurement"]
    sigma = np.array([measurement["sigma_position"]] * 3 +
                     [math.radians(measurement["sigma_angle_deg"])] * 3)
    y = outputs.copy()
    for e in effects:
        if e["kind"] == "sensor_gain":
            c = CHANNELS.index(e["channel"])
            other = (c + 1) % 3 + (3 if c >= 3 else 0)
            y[:, c] = e["gain"] * outputs[:, c] + e["coupling"] * \
                outputs[:, other]
    if noise:
        rng = np.random.default_rng(seed)
        y += rng.standard_normal(y.shape) * sigma
        resolution = np.array(
            [plant["sensors"]["position_resolution"]] * 3 +
            [plant["sensors"]["angle_resolution"]] * 3)
        y = np.round(y / resolution) * resolution
    return y, sigma


EFFECT_KEYS = {
    "maxwell": {"at": None, "k2": 2e6, "c2": 2e4},
    "bouc_wen": {"at": None, "force": 300.0, "sigma": 4e7, "n": 1.5},
    "dahl_one": {"at": None, "force": 300.0, "sigma": 4e7},
    "stiffening": {"at": None, "c2": 4e9, "c3": 4e11},
    "actuator2": {"wn": 60.0, "zeta": 0.7, "delay": 0.005},
    "fixture": {"k": 5e7, "k_rot": 5e5},
    "sensor_gain": {"channel": "z", "gain": 1.02, "coupling": 0.01},
    "friction": {"force": 60.0, "v0": 1e-3},
    "free_play": {"at": None, "gap": 2e-5},
    "drift": {"fraction": -0.05},
}


def parse_effect(text):
    kind, _, rest = text.partition(":")
    if kind not in EFFECT_KEYS:
        raise ValueError(f"--effect {text}: unknown kind (one of "
                         f"{', '.join(EFFECT_KEYS)})")
    effect = {"kind": kind, **EFFECT_KEYS[kind]}
    for pair in filter(None, rest.split(",")):
        key, _, value = pair.partition("=")
        if key not in effect:
            raise ValueError(f"--effect {text}: unknown key {key}")
        effect[key] = value if key in ("at", "channel") else float(value)
    if "at" in effect:
        if effect["at"] is None or not effect["at"].startswith("bushing:"):
            raise ValueError(f"--effect {text}: at=bushing:X needed")
        effect["row"] = BUSHINGS.index(effect["at"].split(":")[1])
    return effect


def write_log(out, times, forces, y, ramp, sigma, noise, seed):
    rows = ["t,Fx,Fy,Fz,x,y,z,toe,camber,caster"]
    for t, f, v in zip(times, forces, y):
        rows.append(",".join(repr(float(a)) for a in
                             [t, *f, *v]))
    out.write_text("\n".join(rows) + "\n")
    sidecar = {
        "format": "kcrig run log 1",
        "units": dict(zip(["t", "Fx", "Fy", "Fz"] + CHANNELS,
                          ["s", "N", "N", "N", "m", "m", "m", "rad", "rad",
                           "rad"])),
        "rate_hz": 1.0 / (times[1] - times[0]),
        "samples": len(times),
        "excitation": {"type": "linear_ramp", "phi_rad": ramp.phi,
                       "z_a_m": ramp.z_a, "fmax_n": ramp.fmax,
                       "tf_s": ramp.duration, "hold_s": ramp.hold,
                       "return_s": ramp.return_duration},
        "measurement_sigma": {"position_m": sigma[0], "angle_rad": sigma[3]},
        "noise": {"added": noise, "seed": seed},
        "transport": "independent generator",
    }
    out.with_suffix(".json").write_text(json.dumps(sidecar, indent=2) + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", type=pathlib.Path, required=True)
    parser.add_argument("--phi", type=float, help="[deg]")
    parser.add_argument("--z", type=float, help="acting height [m]")
    parser.add_argument("--fmax", type=float)
    parser.add_argument("--duration", type=float)
    parser.add_argument("--hold", type=float, default=0.0)
    parser.add_argument("--return", dest="return_duration", type=float,
                        default=0.0)
    parser.add_argument("--rate", type=float)
    parser.add_argument("--set", action="append", default=[])
    parser.add_argument("--effect", action="append", default=[])
    parser.add_argument("--noise", action="store_true")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    parser.add_argument("--truth", type=pathlib.Path)
    parser.add_argument("--noise-free-copy", type=pathlib.Path,
                        help="also the same run without noise")
    args = parser.parse_args()
    try:
        model = Model(args.config)
        for assignment in args.set:
            model.set(assignment)
        effects = [parse_effect(e) for e in args.effect]
    except (ValueError, KeyError, OSError) as error:
        sys.exit(f"independent_rig: {error}")
    excitation = yaml.safe_load(
        (args.config / "experiment.yaml").read_text())["excitation"]
    pick = lambda value, key: excitation[key] if value is None else value
    ramp = Ramp(math.radians(pick(args.phi, "phi_deg")), pick(args.z, "z_a"),
                pick(args.fmax, "fmax"), pick(args.duration, "duration"),
                args.hold, args.return_duration)
    plant = Plant(model, effects, ramp)
    times, outputs = simulate(plant, pick(args.rate, "rate"))
    y, sigma = sensors(outputs, args.config, args.noise, args.seed, effects)
    forces = np.array([ramp.force(t) for t in times])
    write_log(args.out, times, forces, y, ramp, sigma, args.noise, args.seed)
    if args.noise_free_copy:
        clean_y, _ = sensors(outputs, args.config, False, 0, effects)
        write_log(args.noise_free_copy, times, forces, clean_y, ramp, sigma,
                  False, args.seed)
    if args.truth:
        truth = {"set": args.set,
                 "effects": [{k: v for k, v in e.items()
                              if k not in ("state", "row")} for e in effects]}
        args.truth.write_text(json.dumps(truth, indent=2) + "\n")


if __name__ == "__main__":
    main()
