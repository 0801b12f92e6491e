"""Non-learned baselines that write ordinary prediction files."""
