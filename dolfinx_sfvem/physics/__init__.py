"""The physics of a contact run: strain energies, loads, the balance they make, the contact checks."""
