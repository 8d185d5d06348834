"""``rig identify``'s text report: the identified (3.5), its friction and frequency response."""

from __future__ import annotations

from typing import Any

from rig.identify.model_file import FIT_MIN

__all__ = ["print_result"]


def print_result(
    result: Any, run_dir: str, response: dict[str, Any] | None, bode: str | None, path: Any
) -> None:
    """The identification as text on stdout.

    Parameters
    ----------
    result : Any
        The identification (``rig.identify.estimate.IdentResult``).
    run_dir : str
        The run it is of.
    response : dict[str, Any] | None
        The frequency response (a chirp's or a multisine's), or None.
    bode : str | None
        Its Bode plot's file, or None.
    path : Any
        The identification.json written.
    """
    r = result
    filled = f", {r.filled_samples} of skipped cycles filled in" if r.filled_samples else ""
    print(f"identified (3.5) from {r.samples} samples{filled} at T = {r.dt:g} s ({run_dir}):")
    print(f"  input u: {r.input} [{r.input_unit}]")
    for name, unit in (("a_m", "1/s"), ("b_m", r.b_m_unit)):
        value, err, (low, high) = getattr(r, name), getattr(r, f"{name}_stderr"), getattr(r, f"{name}_ci95")
        print(f"  {name} = {value:.5g} {unit}, stderr {err:.2g}, 95 %: {low:.5g} .. {high:.5g}")
    print(f"  delay {r.delay_samples} samples, offset {r.offset:.4g} rad/s^2")
    floor = (
        f" (residual {r.residual_rms:.3g} rad/s RMS, the encoder's quantisation noise "
        f"{r.quantisation_rms:.3g})"
        if r.fit_percent < FIT_MIN
        else ""
    )
    print(f"  fit on held-out data {r.fit_percent:.1f} %{floor}")
    if r.friction is not None:
        _print_friction(r.friction)
    if response is not None:
        _print_response(response)
        if bode:
            print(f"  Bode plot: {bode}")
    print(f"  written to {path}")


def _print_friction(f: dict[str, Any]) -> None:
    if not f["separable"]:
        print(f"  friction: not separated: {f['reason']}")
        return
    said = f"standard errors; speed reversed {f['reversals']} times"
    if f["input"] == "torque":
        print(
            f"  friction: J = {f['inertia']:.5g} kg m^2, viscous B = {f['viscous']:.4g} N m s/rad, "
            f"Coulomb T_c = {f['coulomb']:.4g} +- {f['coulomb_stderr']:.2g} N m ({said})"
        )
    else:
        volts = f"{f['coulomb_voltage']:.4g} +- {f['coulomb_voltage_stderr']:.2g} V"
        print(f"  friction: Coulomb {f['c']:.4g} +- {f['c_stderr']:.2g} rad/s^2 = {volts} ({said}; ", end="")
        print("with a voltage, J and B are not separable from the back EMF)")


def _print_response(doc: dict[str, Any]) -> None:
    band = doc["coherent_band"]
    where = "no bin" if band is None else f"{band[0]:g} .. {band[1]:g} Hz"
    print(
        f"  frequency response ({doc['excitation']}, {doc['f_min']:g} .. {doc['f_max']:g} Hz, "
        f"{doc['averages']} averages): coherence >= {doc['coherence_min']:g} over {where}"
    )
    if doc["worst_db"] is not None:
        print(
            f"  model against the measured response where coherent: worst {doc['worst_db']:.2f} dB, "
            f"{doc['worst_deg']:.1f} deg"
        )
