"""Joints and the linear algebra they bring: constraint rows and their Jacobians
(``joints``, ``jacobian``), the bordered Newton matrix (``kkt``), the factorizations of the
iteration matrix (``factorization``) and held static equilibria (``statics``)."""
