"""Device-side access to an emulated node's object dictionary, fast enough for every SYNC.

canopen's ``LocalNode`` keeps each object's bytes in ``data_store``; its SDO
server and our RPDOs read and write there, so the bytes stay the truth on the
wire. The device reads and writes the same few objects every SYNC, and going
through canopen's ``ODVariable.encode_raw``/``decode_raw`` each time costs
more than the physics. ``ObjectStore`` adds, per object:

- a codec looked up once: the struct of its data type (canopen's own), so an
  integer is packed and unpacked in one call, with canopen's error for a value
  that does not fit;
- the decoded value, cached: set by the device's own writes (integers; other
  types are decoded from the bytes at the next read), dropped when an SDO or
  RPDO write lands (``StoreNode.set_data``) and cleared by ``clear`` when the
  store is rewritten (NMT reset).

Objects with limits in the EDS (LowLimit/HighLimit) go through canopen's
encoder, which warns on a value outside them.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

import canopen
from canopen.objectdictionary import INTEGER_TYPES

__all__ = ["ObjectStore", "StoreNode", "nothing_stored"]


def nothing_stored(index: int, subindex: int) -> None:
    """A ``StoreNode``'s ``on_stored`` until one is set: nothing to tell.

    Parameters
    ----------
    index, subindex : int
        The object written.
    """


class StoreNode(canopen.LocalNode):
    """canopen's ``LocalNode``, telling ``on_stored(index, subindex)`` when an SDO or RPDO write landed."""

    on_stored: Callable[[int, int], None] = staticmethod(nothing_stored)

    def set_data(self, index: int, subindex: int, data: bytes, check_writable: bool = False) -> None:
        """canopen's ``set_data``, then ``on_stored``.

        Parameters
        ----------
        index, subindex : int
            The object.
        data : bytes
            The bytes.
        check_writable : bool, optional
            Refuse an object not writable (an SDO download).
        """
        super().set_data(index, subindex, data, check_writable)
        self.on_stored(index, subindex)

    def store(self, index: int, subindex: int, obj: Any, data: bytes) -> None:
        """``set_data`` for an object already looked up (``obj``) and data of its size (an RPDO's,
        whose mapping was checked): the same write callbacks, then the bytes are stored.

        Parameters
        ----------
        index, subindex : int
            The object.
        obj : Any
            Its OD entry.
        data : bytes
            Bytes of its size.
        """
        for callback in self._write_callbacks:
            callback(index=index, subindex=subindex, od=obj, data=data)
        try:
            self.data_store[index][subindex] = bytes(data)
        except KeyError:
            self.data_store[index] = {subindex: bytes(data)}
        self.on_stored(index, subindex)


class _Codec:
    """How one object's value becomes bytes and back: ``pack`` (an integer, by its struct) or
    ``encode`` (canopen's, for the other types and for objects with limits)."""

    __slots__ = ("decode", "encode", "pack")

    def __init__(self, obj: Any) -> None:
        fmt = obj.STRUCT_TYPES.get(obj.data_type)
        limits = obj.min is not None or obj.max is not None
        self.encode: Callable[[Any], bytes] = obj.encode_raw
        self.decode: Callable[[bytes], Any] = obj.decode_raw
        self.pack: Callable[[int], bytes] | None = None
        if fmt is not None and obj.data_type in INTEGER_TYPES and not limits:
            unpack = fmt.unpack
            self.decode = lambda data: unpack(data)[0]
            self.pack = fmt.pack


class ObjectStore:
    """Typed, cached access to ``node``'s object dictionary (see the module docstring).

    Parameters
    ----------
    node : StoreNode
        The node whose dictionary it is.
    """

    def __init__(self, node: StoreNode) -> None:
        self.node: Any = node
        self.data: dict[int, dict[int, bytes]] = node.data_store
        #: the decoded values by (index, subindex); an entry dropped is decoded again at its next read
        self.values: dict[tuple[int, int], Any] = {}
        self._codecs: dict[tuple[int, int], _Codec] = {}
        self._objs: dict[tuple[int, int], Any] = {}
        node.on_stored = self.forget

    def forget(self, index: int, subindex: int) -> None:
        """The bytes of (index, subindex) changed behind the cache.

        Parameters
        ----------
        index, subindex : int
            The object.
        """
        self.values.pop((index, subindex), None)

    def clear(self) -> None:
        """The store was rewritten: decode everything afresh."""
        self.values.clear()

    def obj(self, index: int, subindex: int) -> Any:
        """The OD entry (canopen ``ODVariable``); SdoAbortedError when there is none.

        Parameters
        ----------
        index, subindex : int
            The object.

        Returns
        -------
        Any
            canopen's ``ODVariable``.
        """
        key = (index, subindex)
        obj = self._objs.get(key)
        if obj is None:
            obj = self._objs[key] = self.node._find_object(index, subindex)
        return obj

    def has(self, index: int, subindex: int = 0) -> bool:
        """The object dictionary has (index, subindex).

        Parameters
        ----------
        index, subindex : int
            The object.

        Returns
        -------
        bool
            It has.
        """
        od = self.node.object_dictionary
        if index not in od:
            return False
        obj = od[index]
        return subindex == 0 if not hasattr(obj, "subindices") else subindex in obj.subindices

    def _codec(self, key: tuple[int, int]) -> _Codec:
        codec = self._codecs.get(key)
        if codec is None:
            codec = self._codecs[key] = _Codec(self.obj(*key))
        return codec

    def raw(self, index: int, subindex: int) -> bytes:
        """Stored bytes of an object (its default before any write).

        Parameters
        ----------
        index, subindex : int
            The object.

        Returns
        -------
        bytes
            Its bytes.
        """
        try:
            return self.data[index][subindex]
        except KeyError:
            return bytes(self.node.get_data(index, subindex))

    def read(self, index: int, subindex: int = 0) -> Any:
        """Decoded value of an object.

        Parameters
        ----------
        index, subindex : int
            The object.

        Returns
        -------
        Any
            Its value.
        """
        key = (index, subindex)
        try:
            return self.values[key]
        except KeyError:
            pass
        value = self.values[key] = self._codec(key).decode(self.raw(index, subindex))
        return value

    def write(self, index: int, subindex: int, value: Any) -> None:
        """Set an object's value from the device side (no access check, no callbacks).

        The value it already has costs a lookup only (its bytes are those of the cached value).

        Parameters
        ----------
        index, subindex : int
            The object.
        value : Any
            Its value.

        Raises
        ------
        ValueError
            If the value does not fit the object's type.
        """
        key = (index, subindex)
        values = self.values
        if key in values and values[key] == value:
            return
        codec = self._codecs.get(key) or self._codec(key)
        if codec.pack is not None:
            value = int(value)
            try:
                data = codec.pack(value)
            except struct.error:
                raise ValueError("Value does not fit in specified type") from None  # as canopen says it
            values[key] = value
        else:
            data = codec.encode(value)
            values.pop(key, None)
        try:
            self.data[index][subindex] = data
        except KeyError:
            self.data[index] = {subindex: data}
