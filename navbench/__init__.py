"""navbench: reproduce and extend "Tracking and Planning with Spatial World Models".

Layers, one direction only:

* math (``navbench.geometry``, ``navbench.sim``, ``navbench.worldmodel``, ``navbench.plan``,
  ``navbench.nav``, ``navbench.track``): arrays in, arrays out; no file I/O, printing, global
  RNG or database access;
* results (``navbench.results``): the results database, scoring presets, score tables and
  paired statistics of stored rows;
* report (``navbench.report``): the HTML report, its sections and figures;
* stages (``navbench.pipeline``): one frozen dataclass config in, one cached artifact out;
  the cache, profiles, executors and ``run_profile``;
* ``navbench.bench`` (speed) and a thin CLI (``navbench.cli``).

``tests/core/test_layout.py`` checks that imports only point down this list.

Conventions shared by every module are documented in :mod:`navbench.geometry`.
"""

__version__ = "0.1.0"
