"""Names and fixed tags of the physical groups every model carries.

Later stages put bearings, joints and loads on these surfaces by name, and dolfinx sees
the tags as facet-tag values, so both are stable: the body is (3, 1); the end faces are
(2, 2) and (2, 3); main journal i is (2, 100 + i) and crank pin i is (2, 200 + i); a
connecting rod's big-end bore is (2, 300) and its small-end bore (2, 301).
"""
from __future__ import annotations

BODY = "body"
BODY_TAG = 1
END_X0, END_XL = "end_x0", "end_xL"
JOURNAL_TAG_BASE = 100
PIN_TAG_BASE = 200
BIG_END, SMALL_END = "big_end", "small_end"
#: A connecting rod's surface groups: the cylindrical faces of its two bores.
CONROD_TAGS = {BIG_END: 300, SMALL_END: 301}


def journal(i: int) -> str:
    """The name of main journal ``i``'s group."""
    return f"journal_{i}"


def pin(i: int) -> str:
    """The name of crank pin ``i``'s group."""
    return f"pin_{i}"


def surface_tags(throws: int | None) -> dict[str, int]:
    """Surface group name → physical tag, for a beam (``throws=None``) or a crankshaft."""
    tags = {END_X0: 2, END_XL: 3}
    if throws is not None:
        tags |= {journal(i): JOURNAL_TAG_BASE + i for i in range(throws + 1)}
        tags |= {pin(i): PIN_TAG_BASE + i for i in range(throws)}
    return tags
