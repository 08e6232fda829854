"""BDDL templates filled in by the scene generators (package data)."""
from pathlib import Path

TEMPLATE_DIR = Path(__file__).resolve().parent
