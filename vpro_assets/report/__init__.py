"""Reports from results: metrics, the paper's tables, plots."""
