"""navbench: reproduce and extend "Tracking and Planning with Spatial World Models".

Layers, one direction only:

* math (``navbench.geometry``, ``navbench.sim``, ``navbench.worldmodel``, ``navbench.plan``,
  ``navbench.nav``, ``navbench.track``): arrays in, arrays out; no file I/O, printing, global
  RNG or database access;
* stages (``navbench.pipeline``): one frozen dataclass config in, one cached artifact out;
* a thin CLI (``navbench.cli``).

Conventions shared by every module are documented in :mod:`navbench.geometry`.
"""

__version__ = "0.1.0"
