"""Haptic coupling to digital waveguides (seed 000): control junctions, estimators, couplings, bow."""
from .core import Block, Buffer, In, Out, Param, State, helper  # noqa: F401
