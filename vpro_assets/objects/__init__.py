"""Generated object assets: MJCF, USD and URDF files, registration in LIBERO, the deformed-object pipeline."""
