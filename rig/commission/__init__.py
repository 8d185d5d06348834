"""Commissioning a drive on a bus, one node at a time: ``drive`` (``rig drive``: status, SDO,
motion checks), ``status`` (a drive's status in words and units) and ``scan`` (``rig scan``: the
nodes on a bus)."""
