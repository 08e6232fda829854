"""LIBERO's initial-state files, read without torch.

A `.pruned_init` file is a torch zip archive around one pickled numpy array (rows of
time, qpos, qvel). Its `data.pkl` unpickles with the standard library once torch's tensor hook
(persistent ids) is refused, which only a file holding real tensors would need.
"""

from __future__ import annotations

import io
import pickle
import zipfile
from pathlib import Path

import numpy as np

from vpro_assets.core.errors import VProError


class _NoTensorUnpickler(pickle.Unpickler):
    def persistent_load(self, pid):
        raise VProError("initial-state file holds torch tensors, not a numpy array; convert it with torch")


def read_init_states(path: Path | str) -> np.ndarray:
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as archive:
            member = next((n for n in archive.namelist() if n.endswith("data.pkl")), None)
            if member is None:
                raise VProError(f"{path}: no data.pkl inside; not a LIBERO initial-state file")
            states = _NoTensorUnpickler(io.BytesIO(archive.read(member))).load()
    except (zipfile.BadZipFile, FileNotFoundError, EOFError, pickle.UnpicklingError) as exc:
        raise VProError(f"{path}: unreadable initial-state file ({exc})") from None
    states = np.asarray(states, dtype=np.float64)
    if states.ndim != 2:
        raise VProError(f"{path}: expected a 2-D array of states, got shape {states.shape}")
    return states
