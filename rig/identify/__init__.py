"""``rig identify``: a_m and b_m of (3.5) from an experiment on the drive, or from a recorded run.

``estimate`` holds the estimator, ``experiment`` runs the excitation through the
host session like any other run.
"""

from rig.identify.estimate import IdentificationError, IdentResult, estimate, excitation, virtual_experiment

__all__ = ["IdentResult", "IdentificationError", "estimate", "excitation", "virtual_experiment"]
