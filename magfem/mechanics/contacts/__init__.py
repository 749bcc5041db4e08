"""Contacts of the body, one module each: the ground, self-contact and the ``[[contacts]]`` kinds.

:mod:`.base` defines the :class:`~magfem.mechanics.contacts.base.Contact`
interface and the registry of ``[[contacts]]`` kinds; :mod:`.penalty` the
penalty law they share. A new contact kind is a new module here whose spec
class registers itself in :data:`~magfem.mechanics.contacts.base.CONTACTS`.
"""

from magfem.mechanics.contacts.base import CONTACTS, Contact, ContactKindSpec
from magfem.mechanics.contacts.ground import GroundContact
from magfem.mechanics.contacts.self_contact import SelfContact
from magfem.plugins import import_modules

__all__ = ["CONTACTS", "Contact", "ContactKindSpec", "GroundContact", "SelfContact"]

import_modules(__name__, __path__)
