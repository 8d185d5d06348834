"""Modbus register maps of inverter families, loaded from the JSON files of this directory.

A register has a role (``control_word``, ``speed_reference``, ``status_word``,
``actual_speed``, ``current``, ``fault_code``, ...), a 0-based holding-register
address, an access (``rw`` or ``ro``), signedness and a factor to SI. Speed
factors depend on the family: ``speed`` means raw * speed_full_scale_rpm /
speed_full_scale_raw in rpm (ABB drives profile), ``frequency`` means 0.01 Hz of
electrical frequency, turned into mechanical rad/s with the pole pairs (Delta).
"""

from __future__ import annotations

import math
import pathlib
from dataclasses import dataclass
from typing import Any

from drivers.files import read_json

__all__ = ["MODBUS_MAPS", "ModbusMap", "Register", "modbus_map"]

HERE = pathlib.Path(__file__).resolve().parent
MODBUS_MAPS = {"abb-drives-profile": "abb_drives_profile.json", "delta-vfd-b": "delta_vfd_b.json"}


@dataclass(frozen=True)
class Register:
    """One holding register: role, 0-based address, access, signedness, raw -> SI factor."""

    role: str  #: what it holds (``speed_reference``)
    address: int  #: 0-based holding-register address
    access: str  #: "ro" or "rw"
    signed: bool  #: a 16-bit two's complement value
    factor: float  #: SI per raw count
    unit: str  #: the SI unit
    note: str  #: the manual's words on it

    def to_si(self, raw: int) -> float:
        """Raw 16-bit register value -> SI.

        Parameters
        ----------
        raw : int
            The 16-bit register value.

        Returns
        -------
        float
            In SI.
        """
        if self.signed and raw >= 0x8000:
            raw -= 0x10000
        return raw * self.factor

    def to_raw(self, value: float) -> int:
        """SI -> raw 16-bit register value; ValueError naming the register when out of range.

        Parameters
        ----------
        value : float
            In SI.

        Returns
        -------
        int
            The 16-bit register value.

        Raises
        ------
        ValueError
            If out of the register's range (it named).
        """
        raw = round(value / self.factor)
        lo, hi = (-0x8000, 0x7FFF) if self.signed else (0, 0xFFFF)
        if not lo <= raw <= hi:
            raise ValueError(f"{self.role} (register {self.address}): {value!r} {self.unit} is out of range")
        return raw & 0xFFFF


@dataclass(frozen=True)
class ModbusMap:
    """A family's register map and its control/status word semantics."""

    name: str  #: the family's name
    title: str  #: in words
    source: str  #: the manual it follows
    registers: dict[str, Register]  #: role -> register
    control: dict[str, Any]  #: the control word's commands
    status: dict[str, Any]  #: the status word's bits

    def __getitem__(self, role: str) -> Register:
        try:
            return self.registers[role]
        except KeyError:
            raise KeyError(f"map {self.name!r} has no register with role {role!r}") from None

    def by_address(self) -> dict[int, Register]:
        """Address -> register.

        Returns
        -------
        dict[int, Register]
            The registers.
        """
        return {r.address: r for r in self.registers.values()}


def modbus_map(name: str) -> ModbusMap:
    """Load the map ``name`` (one of ``MODBUS_MAPS``); ValueError naming it when unknown.

    Parameters
    ----------
    name : str
        One of ``MODBUS_MAPS``.

    Returns
    -------
    ModbusMap
        The map.

    Raises
    ------
    ValueError
        If it is unknown.
    """
    if name not in MODBUS_MAPS:
        raise ValueError(f"unknown Modbus map {name!r}; known: {', '.join(MODBUS_MAPS)}")
    path = HERE / MODBUS_MAPS[name]
    doc = read_json(path, what="Modbus map")
    if "speed_full_scale_rpm" in doc:
        speed = doc["speed_full_scale_rpm"] / doc["speed_full_scale_raw"] * 2.0 * math.pi / 60.0
    else:
        speed = math.nan
    frequency = 0.01 * 2.0 * math.pi / doc.get("pole_pairs", 1)
    regs = {}
    for r in doc["registers"]:
        factor = {"speed": speed, "frequency": frequency}.get(r["factor"], r["factor"])
        regs[r["role"]] = Register(
            r["role"], int(r["address"]), r["access"], bool(r["signed"]), float(factor), r["unit"], r["note"]
        )
    return ModbusMap(doc["name"], doc["title"], doc["source"], regs, doc["control"], doc["status"])
