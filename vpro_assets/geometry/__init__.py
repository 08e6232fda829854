"""Meshes: loading, repair into solids, refinement, deformation, convex decomposition."""
