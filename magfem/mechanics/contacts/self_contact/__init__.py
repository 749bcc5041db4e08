"""Self-contact between cell groups of one body (law, search, coupled terms, the part)."""

from magfem.mechanics.contacts.self_contact.contact import SelfContact
from magfem.mechanics.contacts.self_contact.law import SelfContactLaw, create_self_contact_law

__all__ = ["SelfContact", "SelfContactLaw", "create_self_contact_law"]
