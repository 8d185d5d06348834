"""Protocol definitions shared by the drivers and the emulated devices.

``CIA402_EDS`` and ``CIA406_EDS`` are the object dictionaries (EDS, CiA 306),
written by ``drivers.maps.build_eds``; ``modbus_map(name)`` loads an inverter
register map (JSON, from the vendor's public documentation).
"""

from __future__ import annotations

import pathlib

from drivers.maps.modbus_maps import MODBUS_MAPS, ModbusMap, Register, modbus_map

__all__ = ["CIA402_EDS", "CIA406_EDS", "MAPS_DIR", "MODBUS_MAPS", "ModbusMap", "Register", "modbus_map"]

MAPS_DIR = pathlib.Path(__file__).resolve().parent
CIA402_EDS = str(MAPS_DIR / "cia402_drive.eds")
CIA406_EDS = str(MAPS_DIR / "cia406_encoder.eds")
