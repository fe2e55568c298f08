#!/usr/bin/python3
"""A hostile Modbus master (pymodbus, Debian python3-pymodbus) against a rig
that serves kcrig's register map (config/modbus_map.yaml, high word first).

Usage: hostile_master.py PORT MODE SECONDS
  spoof  another controller owns the rig: read every input and holding
         register, then forge commands with what was read (the owner
         register, the session register, the echoed sequence and the next
         one), with claims and releases, by every write function (6, 16,
         22, 23), commanding Fx = Fy = Fz = 4 kN, for SECONDS, whenever
         the rig is claimed.
  claim  no controller: claim the rig as its master and command what no
         controller would (1e9 N, -1e9 N, NaN, inf, 1e30 N, 5.5 kN on every
         axis, each held 40 ms) for SECONDS, reading the rig back between
         writes.

Prints one line: "hostile MODE: R reads, W writes obeyed, X refused,
max |F| read N, max |xyz| read M m, faults [codes]".
"""
import math
import struct
import sys
import time

from pymodbus.client import ModbusTcpClient

# Holding: control_word 0, sequence 1, fx 2, fy 4, fz 6, za 8, session 10.
# Input: status 0, fault_code 1, sample 2, echo 4, protocol 5, forces 6..11,
# pose 12..23, owner 24, refused 25.
ENABLE, RESET, CLAIM, RELEASE = 1, 2, 4, 8
HOLDING_COUNT, INPUT_COUNT = 11, 26


def words(value):
    return list(struct.unpack(">HH", struct.pack(">f", value)))


def value(registers, at):
    return struct.unpack(">f", struct.pack(">HH", *registers[at:at + 2]))[0]


def command(control, sequence, force, session, z_a=-0.45):
    return ([control, sequence & 0xffff] + words(force) + words(force) +
            words(force) + words(z_a) + [session & 0xffff])


class Tally:
    def __init__(self):
        self.reads = self.obeyed = self.refused = 0
        self.force = self.travel = 0.0
        self.faults = set()

    def read(self, client):
        reply = client.read_input_registers(0, INPUT_COUNT, slave=1)
        if reply.isError():
            return None
        r = reply.registers
        self.reads += 1
        if r[1]:
            self.faults.add(r[1])
        for k in range(3):
            f = value(r, 6 + 2 * k)
            if math.isfinite(f):
                self.force = max(self.force, abs(f))
            x = value(r, 12 + 2 * k)
            if math.isfinite(x):
                self.travel = max(self.travel, abs(x))
        return r

    def write(self, call):
        try:
            reply = call()
        except Exception:  # the rig closed the connection
            self.refused += 1
            return
        if reply.isError():
            self.refused += 1
        else:
            self.obeyed += 1


def spoof(client, tally, end):
    while time.monotonic() < end:
        r = tally.read(client)
        held = client.read_holding_registers(0, HOLDING_COUNT, slave=1)
        if r is None or held.isError():
            continue
        owner, echo = r[24], r[4]
        if owner == 0:
            # Unclaimed (the run has not claimed yet, or has ended): an
            # impostor needs a master to impersonate.
            time.sleep(0.005)
            continue
        for token in {owner, held.registers[10], 1, 0}:
            for seq in (echo, echo + 1):
                for control in (ENABLE, ENABLE | CLAIM, RELEASE,
                                ENABLE | RESET):
                    words16 = command(control, seq, 4000.0, token)
                    tally.write(lambda: client.write_registers(
                        0, words16, slave=1))
            tally.write(lambda: client.write_register(10, token, slave=1))
        tally.write(lambda: client.write_register(0, RELEASE, slave=1))
        tally.write(lambda: client.mask_write_register(0, 0, RELEASE,
                                                       slave=1))
        tally.write(lambda: client.readwrite_registers(
            read_address=0, read_count=1, write_address=0,
            write_registers=command(ENABLE, echo + 1, 4000.0, owner),
            slave=1))


def claim(client, tally, end):
    session, seq = 0x1234, 0
    demands = [1e9, -1e9, float("nan"), float("inf"), 1e30, 4999.0, 5500.0]
    client.write_registers(0, command(CLAIM | RESET, 0, 0.0, session),
                           slave=1)
    while time.monotonic() < end:
        for force in demands:
            # Each demand held for 40 ms (the actuator's lag is 5 ms).
            hold = time.monotonic() + 0.04
            while time.monotonic() < hold:
                seq += 1
                words16 = command(ENABLE | CLAIM, seq, force, session)
                tally.write(lambda: client.write_registers(0, words16,
                                                           slave=1))
                tally.read(client)
                time.sleep(0.002)
    client.write_registers(0, command(RELEASE, seq + 1, 0.0, session),
                           slave=1)


def main():
    port, mode, seconds = int(sys.argv[1]), sys.argv[2], float(sys.argv[3])
    client = ModbusTcpClient("127.0.0.1", port=port)
    if not client.connect():
        print("hostile could not connect", flush=True)
        return 1
    tally = Tally()
    end = time.monotonic() + seconds
    {"spoof": spoof, "claim": claim}[mode](client, tally, end)
    client.close()
    print(f"hostile {mode}: {tally.reads} reads, {tally.obeyed} writes "
          f"obeyed, {tally.refused} refused, max |F| read {tally.force:.1f} "
          f"N, max |xyz| read {tally.travel:.4f} m, faults "
          f"{sorted(tally.faults)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
