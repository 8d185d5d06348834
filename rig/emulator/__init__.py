"""The emulator and ``rig`` in processes of their own: ``serve`` is ``rig emulate`` (the plant
emulator as its own process, on a CAN bus, socketcand or a Modbus line); ``spawn`` starts them
(the emulator for tests and benchmarks, a run to kill) and stops them."""
