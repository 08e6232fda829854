"""LIBERO-VPro: closed-loop visual robustness benchmark on LIBERO.

Importing the package is cheap: LIBERO, robosuite and renderers load only when used.
"""
__version__ = "0.1.0"
