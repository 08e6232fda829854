"""Adapters of the toolkit to outside systems (evaluation harnesses)."""
