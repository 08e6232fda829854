"""Bottom layer: errors, paths, hashing and canonical JSON, atomic writes, seeding, images."""
