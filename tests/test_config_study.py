"""The study's input hash is a cache key users' files carry (reduced.h5 ``input_hash``): the same
study must give the same hash across versions of the code that do not change its meaning."""
from __future__ import annotations

from gcms_fenicsx.config.study import REDUCED_MODEL_TABLES, load_config, parse_config

#: Hashes recorded with the code of 2026-11-24 (d2b8c1b), before the package was reorganised
#: into config/, fe/, reduction/, files/: reduced.h5 files written then are still reused.
DEFAULT_STUDY_HASH = "0424d8625fda33704263580578ca62fd271157714bdb67da201cf5b66880a731"
SLENDER_BEAM_HASH = "c8b2fc00e98ec1c6c3b32b46b50c972a6bcf7b04e9d1e748ff8102b21f65597f"


def test_the_input_hash_of_a_study_is_stable():
    assert load_config(None).digest(*REDUCED_MODEL_TABLES) == DEFAULT_STUDY_HASH
    beam = parse_config({"geometry": {"kind": "beam", "section": "square", "side": 0.01,
                                      "length": 2.0},
                         "mesh": {"order": 2}, "modes": {"count": 6}})
    assert beam.digest(*REDUCED_MODEL_TABLES) == SLENDER_BEAM_HASH


def test_the_hash_follows_the_tables_it_covers():
    """A changed upstream table changes the hash; a changed [scene] does not."""
    base = load_config(None)
    stiffer = parse_config({"geometry": {"kind": "crankshaft", "throws": 4},
                            "mesh": {"order": 2}, "material": {"E": 211e9},
                            "modes": {"count": 10}})
    assert stiffer.digest(*REDUCED_MODEL_TABLES) != base.digest(*REDUCED_MODEL_TABLES)
    unscened = parse_config({"geometry": {"kind": "crankshaft", "throws": 4},
                             "mesh": {"order": 2}, "modes": {"count": 10}})
    assert unscened.digest(*REDUCED_MODEL_TABLES) == base.digest(*REDUCED_MODEL_TABLES)
