"""Frozen scene packs: a self-contained, versioned folder (or archive) of cases in the layout
LIBERO forks use, with a manifest that hashes every file. See docs/packs.md."""
