"""What a run's samples become for people: ``metrics`` (errors, chattering, rise and settling
times, loop margins), ``summary`` (a run's summary in words and units) and ``plots`` (what every
figure is drawn with). Below ``rig.host``: the host's streaming figures use ``metrics``."""
