"""An I/O module with a valve and a pump on it, served by pymodbus's own server.

Each unit (slave) is the same module: the valve's 4-20 mA command in holding
register 0 (raw 4000..20000 uA) and its position feedback in input register 0
(same units), the pump's run command on coil 0 and its run feedback on
discrete input 0, and a flow on input registers 1-2 (float32, high word first).
The feedback follows the command only as the test's clock moves it
("advance"), so thresholds are clock time, not waits.

    python3 io_module.py --port 5020 [--framing socket|rtu] [--serial /dev/pts/3] [--units 1,2]

Control: one JSON object per line on stdin, one answer per line on stdout:
    {"cmd": "advance", "ms": 100}          moves every valve toward its command
    {"cmd": "stick", "unit": 1}            the valve's feedback stops following
    {"cmd": "mute", "unit": 2}             the unit never answers again (its requests hang)
    {"cmd": "get", "unit": 1}              its registers and the writes it received
The first line out is {"ready": true} once the server listens.
"""

import argparse
import asyncio
import json
import logging
import struct
import sys

from pymodbus.framer import FramerType
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

SIZE = 64
RAW_MIN, RAW_MAX = 4000, 20000
SWEEP_MS = 4000  # full travel, closed to open


class Unit:
    def __init__(self, unit):
        self.unit = unit
        self.stuck = False
        self.muted = asyncio.Event()
        self.writes = []  # [function code, address, values] in order
        self.device = SimDevice(
            id=unit,
            use_bit_addressing=True,
            simdata=(bits(), bits(), registers(RAW_MIN), registers(RAW_MIN)),
            action=self.action,
        )

    async def action(self, function_code, start_address, address, count, registers_, set_values):
        if self.muted.is_set():
            await asyncio.Event().wait()  # never answers
        if set_values is not None and function_code in (5, 6, 15, 16):
            values = [int(v) for v in set_values]
            self.writes.append([function_code, address, values])
        return None


def bits():
    return [SimData(0, count=SIZE, values=False, datatype=DataType.BITS)]


def registers(value):
    return [SimData(0, count=SIZE, values=value, datatype=DataType.REGISTERS)]


class Module:
    def __init__(self, server, units):
        self.server = server
        self.units = units

    def block(self, unit, kind):
        return self.server.context.devices[unit].block[kind][2]

    def bit(self, unit, kind, address):
        return bool(self.block(unit, kind)[address // 16] >> (address % 16) & 1)

    def set_bit(self, unit, kind, address, on):
        regs = self.block(unit, kind)
        mask = 1 << (address % 16)
        regs[address // 16] = (regs[address // 16] | mask) if on else (regs[address // 16] & ~mask)

    def advance(self, ms):
        step = (RAW_MAX - RAW_MIN) * ms / SWEEP_MS
        for u in self.units.values():
            holding, inputs = self.block(u.unit, "h"), self.block(u.unit, "i")
            if not u.stuck:
                target, now = holding[0], inputs[0]
                inputs[0] = int(target if abs(target - now) <= step else now + (step if target > now else -step))
            self.set_bit(u.unit, "d", 0, self.bit(u.unit, "c", 0))
            flow = struct.unpack(">HH", struct.pack(">f", (inputs[0] - RAW_MIN) / 160.0))
            inputs[1], inputs[2] = flow

    def get(self, unit):
        u = self.units[unit]
        return {
            "holding": self.block(unit, "h")[:8],
            "input": self.block(unit, "i")[:8],
            "coil": [self.bit(unit, "c", a) for a in range(8)],
            "discrete": [self.bit(unit, "d", a) for a in range(8)],
            "writes": u.writes,
        }


async def control(module):
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader()
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)
    while line := await reader.readline():
        request = json.loads(line)
        cmd, unit = request["cmd"], request.get("unit")
        if cmd == "advance":
            module.advance(request["ms"])
            answer = {"ok": True}
        elif cmd == "stick":
            module.units[unit].stuck = True
            answer = {"ok": True}
        elif cmd == "mute":
            module.units[unit].muted.set()
            answer = {"ok": True}
        elif cmd == "get":
            answer = module.get(unit)
        else:
            answer = {"error": f"unknown command {cmd}"}
        answer["id"] = request.get("id")
        print(json.dumps(answer), flush=True)


async def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, default=5020)
    parser.add_argument("--framing", choices=["socket", "rtu"], default="socket")
    parser.add_argument("--serial")
    parser.add_argument("--units", default="1")
    args = parser.parse_args()
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    units = {int(u): Unit(int(u)) for u in args.units.split(",")}
    devices = [u.device for u in units.values()]
    framer = FramerType.RTU if args.framing == "rtu" else FramerType.SOCKET
    if args.serial:
        server = ModbusSerialServer(devices, framer=FramerType.RTU, port=args.serial, baudrate=19200)
    else:
        server = ModbusTcpServer(devices, framer=framer, address=("127.0.0.1", args.port))
    module = Module(server, units)
    module.advance(0)
    # Listening (or the serial port open) once this returns.
    await server.serve_forever(background=True)
    print(json.dumps({"ready": True}), flush=True)
    await control(module)
    await server.shutdown()


if __name__ == "__main__":
    asyncio.run(main())
