#!/usr/bin/python3
"""A stand-in K&C rig written with pymodbus (Debian python3-pymodbus), serving
kcrig's register map (config/modbus_map.yaml, given as argv[1]) on a free
loopback port, printed as "listening on PORT".

Its plant is deliberately trivial so the test can check every value: a linear
spring of 2e6 N/m per axis (x = Fx / 2e6, ...), angles zero, a load cell that
reads the set-point last written while enabled. Each read of the input
registers takes a new sample (the counter goes up).

It speaks protocol 3 as a rig front end that reports ownership but does not
enforce it: a claim (control word bit 2) with a session token makes that
session the owner, a release (bit 3) ends it, and anyone's write is applied
and echoed. That is what lets the controller's own check (the sequence echo)
be tested against a second master.
"""
import logging
import re
import socket
import struct
import sys
import threading
import time

from pymodbus.datastore import (ModbusSequentialDataBlock,
                                ModbusServerContext, ModbusSlaveContext)
from pymodbus.server import StartTcpServer

STIFFNESS = 2e6  # N/m


def read_map(path):
    regmap, order = {}, "high_word_first"
    for line in open(path):
        line = line.split("#")[0]
        m = re.match(r"\s*(\w+):\s*(\S+)\s*$", line)
        if not m:
            continue
        key, value = m.groups()
        if key == "word_order":
            order = value
        elif re.fullmatch(r"\d+", value):
            regmap[key] = int(value)
    return regmap, order == "high_word_first"


REGMAP, HIGH_FIRST = read_map(sys.argv[1])


def to_words(value, kind):
    raw = struct.pack(">f" if kind == "f" else ">I", value)
    high, low = struct.unpack(">HH", raw)
    return [high, low] if HIGH_FIRST else [low, high]


def from_words(words, kind):
    high, low = (words[0], words[1]) if HIGH_FIRST else (words[1], words[0])
    return struct.unpack(">f" if kind == "f" else ">I",
                         struct.pack(">HH", high, low))[0]


class Holding(ModbusSequentialDataBlock):
    def __init__(self):
        super().__init__(0, [0] * 16)
        self.reported = False
        self.owner = 0

    def setValues(self, address, values):
        super().setValues(address, values)
        control = super().getValues(REGMAP["control_word"], 1)[0]
        session = super().getValues(REGMAP["session"], 1)[0]
        if control & 4 and self.owner == 0:
            self.owner = session
        if control & 8 and session == self.owner:
            self.owner = 0
        z_a = from_words(super().getValues(REGMAP["za_setpoint"], 2), "f")
        if not self.reported and abs(z_a) > 0:
            print(f"pymodbus rig: z_a={z_a:.2f} sequence="
                  f"{super().getValues(REGMAP['sequence'], 1)[0]}", flush=True)
            self.reported = True


class Inputs(ModbusSequentialDataBlock):
    def __init__(self, holding):
        super().__init__(0, [0] * 32)
        self.holding = holding
        self.sample = 0
        super().setValues(REGMAP["protocol"], [3])

    def getValues(self, address, count=1):
        self.sample += 1
        h = self.holding
        enabled = h.getValues(REGMAP["control_word"], 1)[0] & 1
        force = [from_words(h.getValues(REGMAP[k], 2), "f") if enabled else 0.0
                 for k in ("fx_setpoint", "fy_setpoint", "fz_setpoint")]
        set_ = super().setValues
        set_(REGMAP["status"], [1 if enabled else 0])
        set_(REGMAP["fault_code"], [0])
        set_(REGMAP["sample"], to_words(self.sample, "I"))
        set_(REGMAP["sequence_echo"], [h.getValues(REGMAP["sequence"], 1)[0]])
        set_(REGMAP["owner"], [h.owner])
        set_(REGMAP["refused_writes"], [0])
        for name, value in zip(("fx", "fy", "fz"), force):
            set_(REGMAP[name], to_words(value, "f"))
        for name, value in zip(("x", "y", "z"), force):
            set_(REGMAP[name], to_words(value / STIFFNESS, "f"))
        for name in ("toe", "camber", "caster"):
            set_(REGMAP[name], to_words(0.0, "f"))
        return super().getValues(address, count)


def announce_when_listening(port):
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
            print(f"listening on {port}", flush=True)
            return
        except OSError:
            time.sleep(0.05)


def main():
    # pymodbus logs every client disconnect as an error; they are expected.
    logging.disable(logging.CRITICAL)
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    holding = Holding()
    slave = ModbusSlaveContext(hr=holding, ir=Inputs(holding), zero_mode=True)
    context = ModbusServerContext(slaves={REGMAP["unit_id"]: slave},
                                  single=False)
    threading.Thread(target=announce_when_listening, args=(port,),
                     daemon=True).start()
    StartTcpServer(context=context, address=("127.0.0.1", port))


if __name__ == "__main__":
    main()
