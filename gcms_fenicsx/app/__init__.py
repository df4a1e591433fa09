"""The application: the study's plan carried out stage by stage (``pipeline`` the stages as
functions, ``stage_files`` the files they write, ``stage_cache`` what ``--out`` may reuse),
the ``gcms`` verbs (``commands``) and the pictures of a run (``plots``). The top layer: it
may import every other; nothing below imports it (docs/design.md, Layers)."""
