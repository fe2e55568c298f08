"""A peer that no one here wrote: python-can and canmatrix (Debian packages)
against kcrig's CAN protocol, with config/kc_rig.dbc as the only shared
knowledge.

  python_can_peer.py decode DBC CAN_LOG OUT_CSV
      Reads kcrig's bus log with python-can's candump reader, decodes every
      rig sample (the four frames sharing one Counter) with canmatrix and
      writes them, in log order, as Counter,Status,X,Y,Z,Toe,Camber,Caster,
      Fx,Fy,Fz rows.

  python_can_peer.py rig DBC IFACE CYCLES OUT_CSV
      A stand-in rig on IFACE with python-can: takes the first KC_Session
      claim as its owner and names it in KC_Heartbeat, answers each of the
      owner's KC_Command with a sample (X = Counter um, Fx = 0.5 N x
      Counter, enabled while the command enables) for CYCLES commands after
      enable, then falls silent; writes the samples it sent as above.
"""
import decimal
import sys
import time

import can
import canmatrix
import canmatrix.formats

SAMPLE_FRAMES = ("KC_PositionXY", "KC_PositionZToe", "KC_Angles", "KC_Force")
COLUMNS = ("Counter", "Status", "X", "Y", "Z", "Toe", "Camber", "Caster",
           "Fx", "Fy", "Fz")


def load(dbc):
    return canmatrix.formats.loadp_flat(dbc)


def frame_of(db, name):
    frame = db.frame_by_name(name)
    if frame is None:
        sys.exit("no message %s in the DBC" % name)
    return frame


def decode_log(dbc, log_path, out_path):
    db = load(dbc)
    ids = {frame_of(db, n).arbitration_id.id: frame_of(db, n)
           for n in SAMPLE_FRAMES}
    pending = {}
    samples = []
    for message in can.CanutilsLogReader(log_path):
        frame = ids.get(message.arbitration_id)
        if frame is None or message.is_error_frame or message.dlc < 8:
            continue
        values = {k: float(v.phys_value)
                  for k, v in frame.decode(message.data).items()}
        counter = int(values["Counter"])
        if pending.get("Counter") != counter:
            pending = {"Counter": counter, "parts": set()}
        pending.update(values)
        pending["parts"].add(frame.name)
        if len(pending["parts"]) == len(SAMPLE_FRAMES):
            samples.append([pending[c] for c in COLUMNS])
            pending = {}
    write(out_path, samples)
    print("decoded %d samples" % len(samples))


def write(out_path, samples):
    with open(out_path, "w") as out:
        out.write(",".join(COLUMNS) + "\n")
        for s in samples:
            out.write(",".join(repr(v) for v in s) + "\n")


def stand_in_rig(dbc, iface, cycles, out_path):
    db = load(dbc)
    command = frame_of(db, "KC_Command")
    session = frame_of(db, "KC_Session")
    heartbeat = frame_of(db, "KC_Heartbeat")
    frames = [frame_of(db, n) for n in SAMPLE_FRAMES]
    bus = can.Bus(interface="socketcan", channel=iface,
                  can_filters=[{"can_id": f.arbitration_id.id,
                                "can_mask": 0x7FF, "extended": False}
                               for f in (command, session)])

    def send(frame, values):
        bus.send(can.Message(arbitration_id=frame.arbitration_id.id,
                             is_extended_id=False,
                             data=frame.encode(values)))

    enabled = False
    owner = 0
    counter = 0
    answered = 0
    samples = []
    next_heartbeat = 0.0
    # Guest time races ahead while the guest waits for files (vcan_vm.sh).
    deadline = time.monotonic() + 3600
    print("stand-in rig on %s" % iface, flush=True)
    while answered < cycles and time.monotonic() < deadline:
        now = time.monotonic()
        if now >= next_heartbeat:
            send(heartbeat, {"Status": 1 if enabled else 0, "FaultCode": 0,
                             "Protocol": 3, "SampleCounter": counter,
                             "Owner": owner, "Refusing": 0})
            next_heartbeat = now + 0.1
        message = bus.recv(0.01)
        if message is None:
            continue
        if message.arbitration_id == session.arbitration_id.id:
            claim = session.decode(message.data)
            if owner == 0 and int(claim["Claim"].raw_value) == 1:
                owner = int(claim["Session"].raw_value)
                next_heartbeat = 0.0
            continue
        # Answer the newest command only, so a slow interpreter never lags.
        while True:
            newer = bus.recv(0)
            if newer is None or newer.arbitration_id != message.arbitration_id:
                break
            message = newer
        decoded = command.decode(message.data)
        if int(decoded["Session"].raw_value) != owner:
            continue
        enabled = int(decoded["Enable"].raw_value) == 1
        counter = (counter + 1) % 256
        status = 1 if enabled else 0
        # Exact decimals: canmatrix's phys2raw truncates to the raw step.
        d = decimal.Decimal
        sample = {"Counter": d(counter), "Status": d(status),
                  "X": d(counter) / d(10**6), "Y": d("-2e-6"),
                  "Z": d("3e-6"), "Toe": d("4e-6"), "Camber": d("-5e-6"),
                  "Caster": d("6e-6"), "Fx": d(counter) / d(2),
                  "Fy": d("-0.5"), "Fz": d("1.5")}
        for frame in frames:
            send(frame, {s.name: s.phys2raw(sample[s.name])
                         for s in frame.signals})
        samples.append([float(sample[c]) for c in COLUMNS])
        if enabled:
            answered += 1
    bus.shutdown()
    write(out_path, samples)
    print("answered %d enabled commands, then fell silent" % answered,
          flush=True)


def main():
    if len(sys.argv) == 5 and sys.argv[1] == "decode":
        decode_log(sys.argv[2], sys.argv[3], sys.argv[4])
    elif len(sys.argv) == 6 and sys.argv[1] == "rig":
        stand_in_rig(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
