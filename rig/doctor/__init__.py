"""``rig doctor``: whether this PC can run a real-time period, and what to change
(``rig.doctor.probes``: what the kernel gives; ``rig.doctor.verdict``: the floor measured at each
period, a verdict per period, and the advice)."""
