"""Reduction: GCMS fields from the free-free modes, the selection of independent fields, and
the constant reduced matrices Mr, Kr and the gravity matrix (docs/design.md §2, §4, §5)."""
