"""Plans as jobs: the queue and its thread, the operator's controls over them, and the planning front."""
