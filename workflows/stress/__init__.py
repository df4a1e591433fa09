"""The numerical-stability stress suite behind ``workflows/stability.py``, by job:

- :mod:`stress.studies`: the study files (TOML) each probe class writes;
- :mod:`stress.runner`: running ``gcms`` in a child process and judging how it ended;
- :mod:`stress.readers`: what a finished command wrote, as row entries;
- :mod:`stress.measures`: differences between rows, the balance error's growth, beam theory;
- :mod:`stress.suite`: a class's rows and the run of one class;
- :mod:`stress.probes_symmetry`, :mod:`stress.probes_solver`, :mod:`stress.probes_runs`,
  :mod:`stress.probes_assembly`: the eight probe classes;
- :mod:`stress.tables`, :mod:`stress.paragraphs`, :mod:`stress.report`,
  :mod:`stress.figure`: the printed tables, a paragraph per class, docs/stability.md and
  docs/stability.png;
- :mod:`stress.document`: docs/stability.json (merged with the classes not run).
"""
from __future__ import annotations

from common import REPO, log

__all__ = ["CLASSES", "REPO", "log"]

#: The probe classes in the order they run and are reported.
CLASSES = ("symmetry", "units", "slenderness", "modes", "long", "material", "mpi",
           "assembly")
