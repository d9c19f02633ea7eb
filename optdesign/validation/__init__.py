"""Independent checks of our models against other engines (MuJoCo)."""
