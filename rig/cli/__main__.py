"""``python -m rig.cli`` (how ``rig.emulator.spawn.spawn_rig`` starts rig as another process).

Ctrl-C (SIGINT) is how rig is stopped, also when rig started it: a process started from a
script's background job inherits SIGINT ignored, and would then outlive ``stop_rig``; here it
is turned back into KeyboardInterrupt."""

import signal
import sys

from rig.cli import main

if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
sys.exit(main())
