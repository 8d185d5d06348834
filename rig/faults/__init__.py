"""``rig faults``: the fault scenarios and what they are checked with.

``suite`` runs every scenario and tabulates it (in-process, lock-step, over the emulated bus);
``wire`` the scenarios across processes (``rig emulate`` and ``rig run`` in processes of their own,
on socketcand); ``wire_probe`` the watcher of the bus and the link relay they use.
"""
