"""The body and the forces on it: the GCMS body and its frame (``body``), the co-rotated
(``corotated``) and Saint Venant–Kirchhoff (``svk``) elastic laws, the body in the rotor
basis (``rotor``), Rayleigh damping (``damping``) and applied loads (``loads``)."""
