"""robosuite's OSC arm control for one substep as one numba kernel, with the same floating-point
operations as robosuite's Python, on the same operands, in the same order.

What `arm_control.Arms.update` and `Arms.osc_torques` do in about 40 NumPy calls (robosuite's forced
`Controller.update` and `OperationalSpaceController.run_controller`), `osc_substep` does in one
call. Bit for bit the same, by construction:
- every matrix-vector product is numpy's own: numpy 1.26 computes `np.dot(A, x)` of a float64
  matrix and vector as `cblas_dgemv` of its bundled OpenBLAS (row-major for a C-contiguous A,
  column-major for an F-contiguous one, no transpose, alpha 1, beta 0; numpy's
  `cblas_matrixproduct`), and `_dot` calls that same function of that same loaded library with
  the same arguments. numba's own `np.dot` would call scipy's OpenBLAS, another build;
- robosuite's numba kernels (`orientation_error`, `opspace_matrices`, `nullspace_torques`) are
  called on arrays of the types robosuite passes them (the Jacobians and the mass-matrix block
  F-ordered, as numpy's fancy indexing makes them): numba compiles the same code for them;
- `mj_jacSite` and `mj_fullM` are MuJoCo's C functions of the loaded library;
- the rest is copies and elementwise `-`, `*`, `+` written in robosuite's order; numba compiles
  without fast-math, so nothing is contracted into FMAs or reordered.
tests/libero/test_arm_control.py compares every substep with robosuite's own control.

The C functions are called through ctypes (their addresses compiled in), from libraries opened
RTLD_LOCAL. Loading numpy's OpenBLAS and MuJoCo into numba's linker instead
(`load_library_permanently`, calls by symbol name, which numba could cache on disk) made robosuite's
`pinv` fail inside the kernel, in numba's `np.linalg` on scipy's LAPACK
("Insufficient memory for buffer allocation required by LAPACK"; the likely cause, not confirmed:
global symbols of numpy's 64-bit-index OpenBLAS taking the place of scipy's OpenBLAS's own inside
its LAPACK). So the kernel is compiled in each process, at its first call (about 7 s here; about 14 s with
`fused_substeps`'s call around it, which links it in), and only by a process that has run enough
steps to gain it back (`kernel_if_worth_it`).

`kernel()` is None where any of this is not at hand (numpy without its bundled OpenBLAS, robosuite's
kernels not jitted, MuJoCo bindings without raw addresses): `arm_control` then runs its NumPy path.
"""

from __future__ import annotations

import ctypes
import functools
import importlib
import logging
from pathlib import Path

import mujoco
import numpy as np

log = logging.getLogger(__name__)

# CBLAS's enum values (cblas.h)
ROW_MAJOR, COL_MAJOR, NO_TRANS = 101, 102, 111


def _numpy_dgemv():
    """`cblas_dgemv` of the OpenBLAS numpy's wheel bundles (numpy.libs), already loaded by numpy:
    dlopen of the same file gives the same library, with the kernels it chose at load
    (`core.numerics` pins them)."""
    libs = Path(np.__file__).resolve().parent.parent / "numpy.libs"
    for path in sorted(libs.glob("libopenblas*.so*")):
        lib = ctypes.CDLL(str(path))
        for name, index in (("cblas_dgemv64_", ctypes.c_int64), ("cblas_dgemv", ctypes.c_int)):
            fn = getattr(lib, name, None)
            if fn is not None:
                pointer = ctypes.c_size_t  # addresses passed as integers: the same registers on x86-64
                fn.restype = None
                fn.argtypes = [ctypes.c_int, ctypes.c_int, index, index, ctypes.c_double, pointer, index,
                               pointer, index, ctypes.c_double, pointer, index]  # fmt: skip
                return fn
    return None


@functools.cache
def mujoco_library() -> ctypes.CDLL | None:
    """The MuJoCo library its Python bindings loaded (dlopen of the same file: the same library)."""
    found = sorted(Path(mujoco.__file__).parent.glob("libmujoco.so*"))
    return ctypes.CDLL(str(found[0])) if found else None


def _mujoco_functions():
    """MuJoCo's `mj_jacSite` and `mj_fullM` from the library its Python bindings loaded."""
    lib = mujoco_library()
    if lib is None:
        return None
    pointer = ctypes.c_size_t
    jac_site, full_m = lib.mj_jacSite, lib.mj_fullM
    jac_site.restype = full_m.restype = None
    jac_site.argtypes = [pointer, pointer, pointer, pointer, ctypes.c_int]
    full_m.argtypes = [pointer, pointer, pointer]
    return jac_site, full_m


# Compiled in each process (about 7 s here), the kernel saves about 0.1 ms a substep against the
# NumPy path (docs/benchmarks.md): it pays for itself after some 70,000 substeps. The fused
# substeps (compiled with it where unobserved steps run: about 14 s in all) save some 2 ms more
# per unobserved control step: the two pay back after some 3,000-4,000 control steps. So a process runs
# the NumPy path (the same bits) for its first KERNEL_AFTER_STEPS control steps (a certificate, build
# or validation worker: its first few episodes or cases) and the kernel from its next env reset on;
# a short process (one `vpro eval` episode, most tests) never compiles it.
KERNEL_AFTER_STEPS = 2_000
_STEPS_RUN = [0]


def step_run() -> None:
    """Count a control step of this process (`arm_control.Arms.of`)."""
    _STEPS_RUN[0] += 1


def kernel_if_worth_it():
    """`kernel()` once this process has run KERNEL_AFTER_STEPS control steps, else None."""
    return kernel() if _STEPS_RUN[0] >= KERNEL_AFTER_STEPS else None


@functools.cache
def kernel():
    """The compiled-on-first-call `osc_substep`, or None (module docstring)."""
    try:
        import numba
        from numba.core.registry import CPUDispatcher
    except ImportError:
        return None
    osc = importlib.import_module("robosuite.controllers.osc")
    robosuite_kernels = (osc.orientation_error, osc.opspace_matrices, osc.nullspace_torques)
    dgemv, mj = _numpy_dgemv(), _mujoco_functions()
    probe = mujoco.MjModel.from_xml_string("<mujoco/>")
    if (
        dgemv is None
        or mj is None
        or not all(isinstance(k, CPUDispatcher) for k in robosuite_kernels)
        or not hasattr(probe, "_address")
        or not hasattr(mujoco.MjData(probe), "_address")
    ):
        log.info("robosuite's OSC runs through NumPy: numpy's OpenBLAS, robosuite's numba or MuJoCo's C API not found")
        return None
    return _compile(numba, dgemv, *mj, *robosuite_kernels)


def _compile(numba, dgemv, jac_site, full_m, orientation_error, opspace_matrices, nullspace_torques):
    @numba.njit
    def _dot(a, x):
        """np.dot(a, x) of a float64 matrix and vector, as numpy computes it (module docstring)."""
        m, n = a.shape
        if not (a.flags.c_contiguous or a.flags.f_contiguous):
            a = np.ascontiguousarray(a)  # numpy copies such a matrix in C order first
        out = np.zeros(m)
        incx = x.strides[0] // 8
        if a.flags.c_contiguous:
            dgemv(
                ROW_MAJOR, NO_TRANS, m, n, 1.0, a.ctypes.data, max(n, 1), x.ctypes.data, incx, 0.0, out.ctypes.data, 1
            )
        else:
            dgemv(
                COL_MAJOR, NO_TRANS, m, n, 1.0, a.ctypes.data, max(m, 1), x.ctypes.data, incx, 0.0, out.ctypes.data, 1
            )
        return out

    @numba.njit
    def osc_substep(model, data, site, jacp, jacr, full_mass, site_xpos, site_xmat, qpos, qvel, qM, qfrc_bias,
                    qpos_index, qvel_index, goal_pos, goal_ori, kp, kd, initial_joint, uncoupling):  # fmt: skip
        """robosuite's forced `Controller.update` and OSC `run_controller` (`arm_control`): the
        torques before clipping and the attributes `update` sets, in its order. `model`, `data`:
        the MjModel's and MjData's addresses; `jacp`, `jacr`, `full_mass`: buffers MuJoCo writes
        whole; `goal_ori`: the copy robosuite makes (`np.array(self.goal_ori)`)."""
        n = qvel_index.shape[0]
        ee_pos = site_xpos[site].copy()
        ee_ori_mat = site_xmat[site].copy().reshape((3, 3))
        jac_site(model, data, jacp.ctypes.data, jacr.ctypes.data, site)
        ee_pos_vel = _dot(jacp, qvel)
        ee_ori_vel = _dot(jacr, qvel)
        joint_pos = np.empty(qpos_index.shape[0])
        for i in range(qpos_index.shape[0]):
            joint_pos[i] = qpos[qpos_index[i]]
        joint_vel = np.empty(n)
        for i in range(n):
            joint_vel[i] = qvel[qvel_index[i]]
        # F-ordered, as numpy's `jac[:, index]` and robosuite's vstack of two of them
        J_pos = np.empty((n, 3)).T
        J_ori = np.empty((n, 3)).T
        J_full = np.empty((n, 6)).T
        for r in range(3):
            for c in range(n):
                J_pos[r, c] = jacp[r, qvel_index[c]]
                J_ori[r, c] = jacr[r, qvel_index[c]]
                J_full[r, c] = J_pos[r, c]
                J_full[3 + r, c] = J_ori[r, c]
        full_m(model, full_mass.ctypes.data, qM.ctypes.data)
        mass_matrix = np.empty((n, n)).T  # F-ordered, as numpy's `M[index, :][:, index]`
        for r in range(n):
            for c in range(n):
                mass_matrix[r, c] = full_mass[qvel_index[r], qvel_index[c]]
        # run_controller: fixed gains, no interpolators (arm_control checks)
        ori_error = orientation_error(goal_ori, ee_ori_mat)
        desired_force = np.empty(3)
        desired_torque = np.empty(3)
        for i in range(3):
            desired_force[i] = (goal_pos[i] - ee_pos[i]) * kp[i] + (-ee_pos_vel[i]) * kd[i]
            desired_torque[i] = ori_error[i] * kp[3 + i] + (-ee_ori_vel[i]) * kd[3 + i]
        lambda_full, lambda_pos, lambda_ori, nullspace_matrix = opspace_matrices(mass_matrix, J_full, J_pos, J_ori)
        if uncoupling:
            decoupled_wrench = np.concatenate((_dot(lambda_pos, desired_force), _dot(lambda_ori, desired_torque)))
        else:
            decoupled_wrench = _dot(lambda_full, np.concatenate((desired_force, desired_torque)))
        torques = _dot(J_full.T, decoupled_wrench)
        for i in range(n):
            torques[i] = torques[i] + qfrc_bias[qvel_index[i]]  # + torque_compensation
        null = nullspace_torques(mass_matrix, nullspace_matrix, initial_joint, joint_pos, joint_vel)
        for i in range(n):
            torques[i] += null[i]
        return (
            torques,
            ee_pos,
            ee_ori_mat,
            ee_pos_vel,
            ee_ori_vel,
            joint_pos,
            joint_vel,
            J_pos,
            J_ori,
            J_full,
            mass_matrix,
        )

    return osc_substep
