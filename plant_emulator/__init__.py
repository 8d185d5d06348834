"""The other side of the wire: emulated devices and the motor physics behind them."""

from plant_emulator.dc_motor import DCMotor, DCMotorParams, ReducedDCMotor
from plant_emulator.encoder import Encoder
from plant_emulator.zoh import LinearZOH

__all__ = ["DCMotor", "DCMotorParams", "Encoder", "LinearZOH", "ReducedDCMotor"]
