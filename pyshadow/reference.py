"""Deprecated name of :mod:`pyshadow.embree` (the Embree ground truth).

``import pyshadow.reference`` keeps working for one release and warns once;
every name is looked up in :mod:`pyshadow.embree`. (NumPy mirrors of the
kernels are the ``*_reference`` functions beside each kernel's wrapper.)
"""
import warnings

from . import embree as _embree

__all__ = list(_embree.__all__)

warnings.warn("pyshadow.reference is now pyshadow.embree; the old name goes in the next release",
              DeprecationWarning, stacklevel=2)


def __getattr__(name):
    return getattr(_embree, name)
