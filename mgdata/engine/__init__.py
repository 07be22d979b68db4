"""Attempt execution: the executor (plan → execute → gate → record), guarded moves and the initial-state
gate."""
