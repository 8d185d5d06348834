"""The emulator and ``rig`` in processes of their own: ``spawn`` starts them (the emulator for tests
and benchmarks, a run to kill) and stops them."""
