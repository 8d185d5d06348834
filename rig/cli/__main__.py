"""``python -m rig.cli`` (how ``rig.emulator.spawn.spawn_rig`` starts rig as another process): the
same ``main`` as the console script ``rig``, which answers SIGINT and SIGTERM whatever the
parent set (``rig.cli._answer_signals``)."""

import sys

from rig.cli import main

sys.exit(main())
