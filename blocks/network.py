"""The old home of the mass-spring network (before blocks/massspring/): plugins and tools written
against it import MassSpring, Network and parse_ref from here."""
from .massspring import MassSpring, Network, parse_ref

__all__ = ["MassSpring", "Network", "parse_ref"]
