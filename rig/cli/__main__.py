"""``python -m rig.cli`` (how ``rig.emulator.spawn.spawn_rig`` starts rig as another process): the
same ``entry`` as the console script ``rig``, which answers SIGINT and SIGTERM whatever the
parent set (``rig.cli._answer_signals``)."""

from rig.cli import entry

entry()
