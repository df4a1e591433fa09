"""Data files shipped with the package (the built-in default study)."""
