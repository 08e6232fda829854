"""Benchmark data: taxonomy (96 settings), applicability, the catalog, selection, the scene artifact lock."""
