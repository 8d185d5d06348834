"""A Modbus inverter speed run: the host sets a speed, runs, reads back speed and current, stops.

Against the emulated inverter (ABB drives profile map, Modbus TCP on 127.0.0.1) by default:

    python examples/modbus_inverter_speed.py
    python examples/modbus_inverter_speed.py --host 192.168.1.20 --port 502 --unit 1   # a real drive

A Modbus exception from the drive (for example a write to a read-only register)
arrives as drivers.errors.ModbusExceptionResponse with its code and register.
"""

from __future__ import annotations

import argparse
import asyncio
import math
import socket
import threading
import time

from drivers.modbus_inverter import ModbusInverter
from plant_emulator.modbus_inverter import default_model, serve_tcp


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--host", help="inverter address (default: start the emulated one)")
    parser.add_argument("--port", type=int, default=502)
    parser.add_argument("--unit", type=int, default=1)
    parser.add_argument("--family", default="abb-drives-profile", help="register map in drivers/maps")
    parser.add_argument("--speed", type=float, default=100.0, help="speed reference [rad/s]")
    parser.add_argument("--seconds", type=float, default=2.0, help="how long to run")
    args = parser.parse_args(argv)
    host, port = args.host, args.port
    stop = threading.Event()
    if host is None:  # the emulated inverter in a background thread
        host, port = "127.0.0.1", _free_port()
        model = default_model(args.family)

        def serve() -> None:
            async def run() -> None:
                task = asyncio.create_task(serve_tcp(model, host=host, port=port, unit=args.unit, dt=0.005))
                while not stop.is_set():
                    await asyncio.sleep(0.02)
                task.cancel()
                await asyncio.gather(task, return_exceptions=True)

            asyncio.run(run())

        threading.Thread(target=serve, daemon=True).start()
        time.sleep(0.3)
    drive = ModbusInverter(args.family, unit=args.unit, host=host, tcp_port=port)
    drive.connect()
    try:
        drive.run(args.speed)
        t_end = time.monotonic() + args.seconds
        while time.monotonic() < t_end:
            time.sleep(0.25)
            speed, current = drive.read("actual_speed"), drive.read("current")
            print(f"speed {speed:8.2f} rad/s ({speed * 30 / math.pi:7.1f} rpm)   current {current:5.2f} A")
        result = {
            "speed": drive.read("actual_speed"),
            "current": drive.read("current"),
            "fault": drive.read("fault_code"),
        }
    finally:
        drive.stop()
        drive.close()
        stop.set()
    return result


if __name__ == "__main__":
    main()
