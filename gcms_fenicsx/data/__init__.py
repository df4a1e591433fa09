"""Data files shipped with the package: the built-in default system study of ``gcms run``
(crank_train.toml, the inline-4 crank train) and the one-body crankshaft study
(default.toml, ``config.study.default_config_text``)."""
