"""``rig drive store`` / ``restore``: a drive's parameters into its non-volatile memory, or its
defaults back, by CiA 301's 0x1010 / 0x1011 sub 1 (all parameters).

Before anything is written: the drive is identified against its dictionary
(``Cia402Axis.discover``); the dictionary must declare the sub-index writable (an EDS without it
says the drive keeps nothing on command; the toolkit's generic dictionary stands for CiA 301,
which declares it read-write); the drive's own answer to a read of it must have bit 0 set (it
stores, or restores, on command), where it answers one; and the person at the terminal confirms
(``confirm``, a question naming the drive). Then the signature is written as UNSIGNED32: "save"
(0x65766173) or "load" (0x64616F6C), with a longer SDO timeout than a read's, as a drive may take
a while to write its flash. Defaults restored are in force after the drive's next reset (CiA 301):
``reset`` sends NMT reset node and waits for its boot-up, refused while the drive is enabled (a
reset drops its torque) or while another master is on the bus.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from drivers.cia402_pdo import variable
from drivers.errors import ConfigError, RigError, SdoAbort
from drivers.maps import cia
from drivers.maps.cia import PowerState, SdoAbortCode
from drivers.maps.sdo_aborts import abort_text
from drivers.sdo_errors import sdo_errors

__all__ = ["STORE_TIMEOUT", "question", "store"]

STORE_TIMEOUT = 5.0  #: [s] the SDO answer to a store or restore is awaited (a flash write)
_ABSENT = (SdoAbortCode.NO_OBJECT, SdoAbortCode.NO_SUBINDEX)
#: (object, signature, its text, what it does) of each action
_OF = {
    False: (cia.STORE_PARAMETERS, cia.SAVE_SIGNATURE, "save", "store"),
    True: (cia.RESTORE_DEFAULTS, cia.LOAD_SIGNATURE, "load", "restore"),
}


def question(axis: Any, restore: bool) -> str:
    """What the person at the terminal is asked before the write.

    Parameters
    ----------
    axis : Any
        The drive.
    restore : bool
        Restore the defaults (else store).

    Returns
    -------
    str
        The question.
    """
    index, _, text, _ = _OF[restore]
    who = f"Node {axis.node_id} ({axis.device_id.text()})"
    if restore:
        return (
            f"{who}: replace every parameter it has stored by its default, in force at its next reset "
            f"(0x{index:04X}:01 = {text!r})?"
        )
    return (
        f"{who}: store the parameters it holds now in its non-volatile memory, over those stored "
        f"before (0x{index:04X}:01 = {text!r})?"
    )


def _check(axis: Any, restore: bool) -> None:
    """ConfigError where the dictionary or the drive says it does not store (restore) on command."""
    index, _, _, verb = _OF[restore]
    where = f"rig drive {verb}: node {axis.node_id}"
    var = variable(axis.node.object_dictionary, (index, 1))
    own = axis.eds_given or axis.toolkit_drive
    if var is None and own:
        raise ConfigError(
            f"{where}: its EDS {axis.eds} has no 0x{index:04X}:01: the drive does not {verb} its "
            "parameters on command (its manual says how it keeps them); nothing was written"
        )
    if var is not None and not var.writable:
        raise ConfigError(
            f"{where}: 0x{index:04X}:01 ({var.name}) is {var.access_type} in {axis.eds}; nothing was written"
        )
    try:
        said = int.from_bytes(axis.sdo_upload(index, 1)[:4], "little")
    except SdoAbort as exc:
        if exc.code in _ABSENT:
            raise ConfigError(
                f"{where}: the drive has no 0x{index:04X}:01 (SDO abort 0x{exc.code:08X}: "
                f"{abort_text(exc.code)}); nothing was written"
            ) from None
        return  # it answers no read of it (write-only on some drives): its write will say
    if not said & 1:
        raise ConfigError(
            f"{where}: 0x{index:04X}:01 = 0x{said:08X}: bit 0 is clear, the drive does not {verb} its "
            "parameters on command; nothing was written"
        )


def store(tool: Any, *, restore: bool, confirm: Callable[[str], bool], reset: bool = False) -> dict[str, Any]:
    """Store the drive's parameters (restore its defaults, with ``reset`` a reset node after);
    see the module docstring. RigError where the person does not confirm.

    Parameters
    ----------
    tool : Any
        The drive.
    restore : bool
        Restore the defaults (else store).
    confirm : Callable[[str], bool]
        Asks the person.
    reset : bool, optional
        A reset node after.

    Returns
    -------
    dict[str, Any]
        The report.

    Raises
    ------
    RigError
        If the person does not confirm.
    """
    a = tool.axis
    index, signature, text, verb = _OF[restore]
    a.discover(check_mode=False)  # the device against its dictionary, before anything is written
    _check(a, restore)
    if reset:
        _may_reset(tool)
    if not confirm(question(a, restore)):
        raise RigError(f"rig drive {verb}: not confirmed; nothing was written")
    sdo = a.node.sdo
    timeout, sdo.RESPONSE_TIMEOUT = sdo.RESPONSE_TIMEOUT, max(sdo.RESPONSE_TIMEOUT, STORE_TIMEOUT)
    try:
        with sdo_errors(
            f"SDO download of {text!r}", index, 1, node_id=a.node_id, axis=a.axis_number, eds=a.eds
        ):
            sdo.download(index, 1, signature.to_bytes(4, "little"))
    finally:
        sdo.RESPONSE_TIMEOUT = timeout
    result = {
        "node": a.node_id,
        "identity": a.device_id.text(),
        "object": f"0x{index:04X}:01",
        "written": text,
        "reset": False,
    }
    if restore and reset:
        a.nmt("RESET")
        tool.until(lambda: a.watch.booted, 5.0, "the boot-up after the reset")
        result["reset"] = True
    return result


def _may_reset(tool: Any) -> None:
    """ConfigError, before anything is written, where an NMT reset node would drop a drive's
    torque; OtherMaster where another master is on the bus."""
    a = tool.axis
    state = a.read_power_state()
    if state in (PowerState.OPERATION_ENABLED, PowerState.QUICK_STOP_ACTIVE):
        raise ConfigError(
            f"rig drive restore --reset: node {a.node_id} is {state.value}: a reset node drops its torque; "
            "disable it first (rig drive disable); nothing was written"
        )
    tool.alone()


def result_lines(result: dict[str, Any]) -> list[str]:
    """The text report of a store or a restore."""
    node, obj = result["node"], result["object"]
    if result["written"] == "save":
        return [f"stored          node {node}'s parameters are in its non-volatile memory ({obj} = 'save')"]
    lines = [f"restored        node {node}'s defaults replace its stored parameters ({obj} = 'load')"]
    if result["reset"]:
        lines.append(f"reset           node {node} was reset and booted: its defaults are in force")
    else:
        lines.append(
            f"not yet         in force after node {node}'s next reset: power it off and on, or rig drive "
            "restore --reset (NMT reset node)"
        )
    return lines
