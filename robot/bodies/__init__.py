"""The bodies the core drives: the MuJoCo simulation (`sim`) and the real robot on its servo bus (`hardware`)."""
