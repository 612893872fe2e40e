"""The old home of the link laws (now blocks/massspring/laws.py): plugins written against it
import Law from here."""
from .massspring.laws import LAWS, Law

__all__ = ["LAWS", "Law"]
