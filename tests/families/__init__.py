"""Families that live only in the tests (docs/new-family.md, followed once)."""
