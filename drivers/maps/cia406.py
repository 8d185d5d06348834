"""CiA 406 wire constants: the object indices of a rotary encoder, for its driver and its emulator."""

from __future__ import annotations

__all__ = [
    "ENCODER_CYCLIC_TIMER",
    "ENCODER_OPERATING_PARAMETERS",
    "ENCODER_POSITION",
    "ENCODER_RESOLUTION",
    "ENCODER_SINGLETURN_RESOLUTION",
    "ENCODER_SPEED",
]

ENCODER_OPERATING_PARAMETERS = 0x6000
ENCODER_RESOLUTION = 0x6001  #: measuring units per revolution
ENCODER_POSITION = 0x6004  #: [increments]
ENCODER_SPEED = 0x6030  #: sub 1: speed value channel 1 [increments/s], INTEGER16
ENCODER_CYCLIC_TIMER = 0x6200  #: [ms]
ENCODER_SINGLETURN_RESOLUTION = 0x6501
