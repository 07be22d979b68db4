"""Locked OOD scenarios: which condition an attempt runs under, the scenario store and its chunk store,
contact sheets and the ``scenarios`` commands (docs/scenarios.md)."""
