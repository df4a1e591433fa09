"""Reduction: the selection of independent GCMS fields and the constant reduced matrices Mr,
Kr and the gravity matrix (docs/design.md §4, §5); the fields themselves are built on the
mesh by ``fe.basis``."""
