"""Configuration: the study file (TOML), one table per stage, validated into frozen dataclasses.

Pure Python with NumPy at most: nothing here imports the finite-element stack, so a study
can be read and checked (and the standalone integrator can read its ``[scene]``) anywhere.
``table`` reads one table, naming key, value and what is allowed; ``study`` composes the
tables into a :class:`~gcms_fenicsx.config.study.StudyConfig`; ``geometry``, ``material``,
``modes`` and ``selection`` parse their tables (``[scene]`` is ``config.scene``'s).
"""
