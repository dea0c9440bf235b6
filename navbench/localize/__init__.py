"""Image-based localisation with no initial pose (issue 14, RNR-Map supplementary C.2-C.3).

Math layer: arrays in, arrays out (no I/O, printing or database). :class:`Localizer` is built
once per (world model, camera) from a bank of panoramic signatures rendered over a lattice of
free poses, then :meth:`Localizer.localize` answers a single RGB-D frame with ranked
:class:`Hypothesis` poses. See :mod:`navbench.localize.localizer`.
"""

from navbench.localize.localizer import Bank, Hypothesis, LocalizationError, Localizer, LocalizerConfig

__all__ = ["Bank", "Hypothesis", "LocalizationError", "Localizer", "LocalizerConfig"]
