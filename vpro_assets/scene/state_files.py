"""Frozen initial states on disk, byte for byte reproducible.

- LIBERO's format: a torch zip archive (`archive/data.pkl`, `archive/version`) around one pickled
  float64 numpy array, exactly the layout of LIBERO's own `.pruned_init` files, so LIBERO's
  `torch.load(path)` and `vpro_assets.libero.init_states.read_init_states` both read it. Written without
  torch: stored (uncompressed) members with a fixed timestamp, protocol-2 pickle like torch's.
- `.npz`: `states` (rows of time, qpos, qvel), written with fixed member timestamps.
"""

from __future__ import annotations

import io
import pickle
import zipfile

import numpy as np

FIXED_TIME = (1980, 1, 1, 0, 0, 0)


def _zip(members: list[tuple[str, bytes]]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as archive:
        for name, data in members:
            info = zipfile.ZipInfo(name, date_time=FIXED_TIME)
            info.compress_type = zipfile.ZIP_STORED
            info.external_attr = 0o600 << 16
            archive.writestr(info, data)
    return buffer.getvalue()


def libero_init_bytes(states: np.ndarray) -> bytes:
    """Bytes of a LIBERO `.pruned_init` file holding `states`."""
    array = np.ascontiguousarray(np.asarray(states, dtype=np.float64))
    return _zip([("archive/data.pkl", pickle.dumps(array, protocol=2)), ("archive/version", b"3\n")])


def npz_bytes(states: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, np.ascontiguousarray(np.asarray(states, dtype=np.float64)), allow_pickle=False)
    return _zip([("states.npy", buffer.getvalue())])


def read_npz(path) -> np.ndarray:
    with np.load(path, allow_pickle=False) as data:
        return np.asarray(data["states"])
