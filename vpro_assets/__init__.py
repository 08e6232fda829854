"""LIBERO-VPro: closed-loop visual robustness benchmark on LIBERO.

Importing the package is cheap: LIBERO, robosuite and renderers load only when used.
`vpro_assets.wrap(env, case)` puts a case's observation perturbations around a fork's env.
"""
__version__ = "0.1.0"


def wrap(env, case):
    """See `vpro_assets.packs.wrap`."""
    from vpro_assets.packs.wrap import wrap as _wrap

    return _wrap(env, case)
