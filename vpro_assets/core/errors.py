"""One exception family for everything a user can get wrong or the machine can lack.

Messages name the offending id, value or file, so the CLI prints them without a traceback.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class VProError(Exception):
    """Base of every error the toolkit raises on purpose."""


class UnknownIdError(VProError, KeyError):
    """An id (task, setting, case, category...) that does not exist; suggests close matches."""

    def __init__(self, kind: str, value: str, known: Iterable[str]):
        known = list(known)
        close = difflib.get_close_matches(value, known, n=5, cutoff=0.5)
        # Also offer ids that contain the value, which catches short prefixes like "spatial-03".
        close += [k for k in known if value and value in k and k not in close][: max(0, 5 - len(close))]
        hint = (
            f"; did you mean: {', '.join(close)}?" if close else f"; {len(known)} known {kind} ids (see `vpro --help`)"
        )
        super().__init__(f"unknown {kind} id {value!r}{hint}")
        self.kind, self.value, self.suggestions = kind, value, close

    def __str__(self) -> str:  # KeyError would otherwise quote the whole message
        return self.args[0]


class CatalogError(VProError):
    """The catalog file is unreadable, of another schema, or differs from a rebuild."""


class LiberoSetupError(VProError):
    """LIBERO, its assets or a headless OpenGL backend is missing or misconfigured."""


class InvalidParameterError(VProError, ValueError):
    """A parameter value outside what a setting or function accepts."""


class GeneratorError(VProError):
    """A scene generator cannot produce a case (named with the case and the reason)."""
