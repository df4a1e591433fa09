"""SHA-256 checksums of files and of JSON documents, so that a cached file can be verified
without the stage cache's manifest.

A sealed JSON document carries ``document_sha256``: the SHA-256 of its own strict JSON text
with sorted keys and that entry left out (``files.outputs.json_text``). A float survives the
JSON round trip exactly (shortest repr), so the digest of the parsed document is the one
written; any edit of a value, key or nesting changes it.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from gcms_fenicsx.files.outputs import finite_json

#: The entry of a sealed JSON document that holds its checksum.
DOCUMENT_CHECKSUM = "document_sha256"


def file_sha256(path: Path) -> str:
    """SHA-256 of a file's bytes, read in blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def document_digest(document: dict) -> str:
    """SHA-256 of ``document`` without its checksum entry, as sorted strict JSON."""
    body = {key: value for key, value in document.items() if key != DOCUMENT_CHECKSUM}
    text = json.dumps(finite_json(body), sort_keys=True, allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def sealed_document(document: dict) -> dict:
    """``document`` with its ``document_sha256`` entry (:func:`document_digest`)."""
    return {**document, DOCUMENT_CHECKSUM: document_digest(document)}


def document_intact(document: Any) -> bool | None:
    """Whether a parsed JSON document matches its own checksum; None if it carries none
    (written by an earlier version, or not a document)."""
    if not isinstance(document, dict) or not isinstance(document.get(DOCUMENT_CHECKSUM), str):
        return None
    return document[DOCUMENT_CHECKSUM] == document_digest(document)
