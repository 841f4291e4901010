"""Deprecated name of :mod:`pyshadow.embree` (the Embree ground truth).

``import pyshadow.reference`` keeps working for one release and warns once;
use :mod:`pyshadow.embree`. (NumPy mirrors of the kernels are the
``*_reference`` functions beside each kernel's wrapper.)
"""
import warnings

from .embree import *  # noqa: F401,F403
from .embree import __all__  # noqa: F401

warnings.warn("pyshadow.reference is now pyshadow.embree; the old name goes in the next release",
              DeprecationWarning, stacklevel=2)
