"""The old home of the mass-spring blocks (now blocks/massspring/cells.py and links.py): code
written against it imports the block types from here."""
from .massspring import Cell, Contact, Lattice, Spring

__all__ = ["Cell", "Contact", "Lattice", "Spring"]
