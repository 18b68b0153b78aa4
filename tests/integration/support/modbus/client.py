"""pymodbus's own client, for tests: runs the requests given as JSON on argv[1]
against a Modbus TCP server and prints each answer as JSON, one per line.

    python3 client.py '{"port": 5020, "requests": [["read_input_registers", 0, 4, 1], ["write_register", 0, 20000, 1]]}'

A request is [method, address, count or value, unit]; an answer is
{"registers": [...]}, {"bits": [...]}, {"ok": true} or {"error": "..."}.
"""

import asyncio
import json
import logging
import sys

from pymodbus.client import AsyncModbusTcpClient


async def main(spec):
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    client = AsyncModbusTcpClient(spec.get("host", "127.0.0.1"), port=spec["port"], timeout=2, retries=0)
    await client.connect()
    for method, address, arg, unit in spec["requests"]:
        try:
            if method.startswith("read"):
                reply = await getattr(client, method)(address, count=arg, device_id=unit)
            else:
                reply = await getattr(client, method)(address, arg, device_id=unit)
            if reply.isError():
                answer = {"error": str(reply)}
            elif method in ("read_coils", "read_discrete_inputs"):
                answer = {"bits": [bool(b) for b in reply.bits[:arg]]}
            elif method.startswith("read"):
                answer = {"registers": reply.registers}
            else:
                answer = {"ok": True}
        except Exception as exc:  # pylint: disable=broad-except
            answer = {"error": f"{type(exc).__name__}: {exc}"}
        print(json.dumps(answer), flush=True)
    client.close()


if __name__ == "__main__":
    asyncio.run(main(json.loads(sys.argv[1])))
