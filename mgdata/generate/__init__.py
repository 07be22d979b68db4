"""Generation runs: attempts in canonical order (local workers or Ray), resume, shards and merge, summaries,
the whole suite, task reports and the ``generate``/``preview``/``merge``/``tasks`` commands."""
