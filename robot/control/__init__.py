"""Control layer: postures, safe stop (walking and whole-body control plug in here)."""
