"""The live view of a run (``rig run --live``, ``rig drive ... --live``): each axis's
reference, measurement and command as the rows arrive, in a matplotlib window
(``window``) or as a strip on stderr (``terminal``), drawn by a thread of its own a few
times a second from the rows the recorder appends (``view``); ``backend`` says what draws
them; ``channels`` says which columns are which axis's."""

from rig.live.channels import Channel, channels_of
from rig.live.view import MODES, LiveUnavailable, LiveView, open_live

__all__ = ["MODES", "Channel", "LiveUnavailable", "LiveView", "channels_of", "open_live"]
