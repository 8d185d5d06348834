"""The hooks of an emulated CANopen device: what a device built on ``EmulatedNode`` (a drive,
an encoder) overrides to do its work, each called by the node at the moment its docstring names.
The node does the CiA 301 part (NMT, SDO, PDOs, SYNC, heartbeat, supervision); a hook does
nothing unless overridden."""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["DeviceHooks"]


class DeviceHooks:
    """The hooks ``EmulatedNode`` calls (a mixin; see the module docstring)."""

    clock_source: Callable[[], float] | None  #: set by ``EmulatedNode``: None in lock-step

    def sync_time(self, timestamp: float) -> float:
        """The device time [s] at a SYNC stamped ``timestamp`` [s], after ``on_sync_latch``:
        the emulator's clock in real time, else the stamp. A device whose time is the SYNC
        count (lock-step across processes, where a stamp is the host's wall clock) overrides
        it, so its heartbeat consumer and RPDO deadlines count SYNCs as the host does.

        Parameters
        ----------
        timestamp : float
            [s] the SYNC's stamp.

        Returns
        -------
        float
            [s] the device's time.
        """
        return timestamp if self.clock_source is None else self.clock_source()

    def on_sync_latch(self, timestamp: float) -> None:
        """SYNC arrived at ``timestamp`` [s]: advance and latch process data.

        Parameters
        ----------
        timestamp : float
            [s] the SYNC's stamp.
        """

    def on_rpdo(self, number: int, *, synchronous: bool) -> None:
        """RPDO ``number`` (0-based) was written into the object dictionary.

        Parameters
        ----------
        number : int
            The RPDO, 0-based.
        synchronous : bool
            Its transmission type is synchronous (applied at the next SYNC).
        """

    def on_reset(self, *, application: bool) -> None:
        """NMT reset node (application) or power-on.

        Parameters
        ----------
        application : bool
            Reset node (else power-on).
        """

    def after_write(self, index: int) -> None:
        """An SDO or RPDO write to ``index`` was stored.

        Parameters
        ----------
        index : int
            The object written.
        """

    def on_abort_connection(self, what: str, code: int) -> None:
        """The connection to the host is lost (``what``; EMCY code ``code``): a drive's 0x6007.

        Parameters
        ----------
        what : str
            What was lost, in words.
        code : int
            The EMCY code to send.
        """

    def on_write(self, index: int, subindex: int, data: bytes) -> None:
        """An SDO or RPDO write of ``data`` to (index, subindex) is about to be stored; an
        ``SdoAbortedError`` refuses it.

        Parameters
        ----------
        index, subindex : int
            The object.
        data : bytes
            The bytes to store.

        Raises
        ------
        SdoAbortedError
            To refuse the write (its abort code says why).
        """
