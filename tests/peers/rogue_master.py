#!/usr/bin/python3
"""A second Modbus master, as a careless operator's tool would be: connects
to a rig that another controller drives and writes "enable, Fz = FORCE" into
kcrig's holding registers (config/modbus_map.yaml, high word first) as fast
as it can for SECONDS, with pymodbus (Debian python3-pymodbus).

Usage: rogue_master.py PORT FORCE SECONDS
Prints "rogue wrote N commands, M refused" when done.
"""
import struct
import sys
import time

from pymodbus.client import ModbusTcpClient

CONTROL_WORD = 0  # holding registers: control_word, sequence, fx, fy, fz, za


def float_words(value):
    return list(struct.unpack(">HH", struct.pack(">f", value)))


def main():
    port, force, seconds = int(sys.argv[1]), float(sys.argv[2]), float(
        sys.argv[3])
    # (pymodbus 3.0 turns a fractional timeout into 0: a non-blocking connect)
    client = ModbusTcpClient("127.0.0.1", port=port)
    if not client.connect():
        print("rogue could not connect", flush=True)
        return 1
    words = ([1, 0] + float_words(0.0) + float_words(0.0) +
             float_words(force) + float_words(-0.45))
    written = refused = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            reply = client.write_registers(CONTROL_WORD, words, slave=1)
        except Exception:  # the rig closed the connection: keep trying
            refused += 1
            time.sleep(0.01)
            client.connect()
            continue
        if reply.isError():
            refused += 1
        else:
            written += 1
    client.close()
    print(f"rogue wrote {written} commands, {refused} refused", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
