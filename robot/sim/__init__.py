"""MuJoCo simulation backend."""
