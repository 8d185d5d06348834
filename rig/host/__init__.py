"""The host: the SYNC-driven loop over a rig's axes, its pacing and real time, safety and stops,
the session that sets a run up, and the recorder of what it measured."""
