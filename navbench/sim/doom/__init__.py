"""The ViZDoom backend: the paper's own engine as navbench's camera and pose (issue 37 §1, §2).

Modules (import them directly; this package imports nothing, and nothing here imports
``vizdoom`` until an engine starts; ``pip install 'navbench[vizdoom]'`` installs it):

* :mod:`navbench.sim.doom.wad` -- a level as a UDMF Doom map in a PWAD (pure; written by hand,
  see its docstring for why not ``omgifol``).
* :mod:`navbench.sim.doom.engine` -- :class:`~navbench.sim.doom.engine.DoomEngine`: one
  headless ``vizdoom.DoomGame`` moved by teleport, its calibrated projection and depth map.
* :mod:`navbench.sim.doom.simulator` -- :class:`~navbench.sim.doom.simulator.DoomSimulator`:
  :class:`navbench.sim.world.Simulator`'s interface, dynamics and collisions, the engine's pose
  and images.

Scale: 1 map unit = 1 cm, so the engine's integer ``warp`` gives the paper's two decimals. At
that scale Doom's player would have its eye 41 units (0.41 m) above the floor and a 16-unit
(0.16 m) radius; the converted WAD carries a player class (DECORATE + KEYCONF) with the eye at
navbench's camera height (50 units = 0.5 m; read back as ``CAMERA_POSITION_Z``) and the agent's
radius (10 units = 0.1 m). Collisions are navbench's; the radius only keeps the engine from
lifting the player onto a neighbouring raised floor.

Measured with vizdoom 1.3.2 (``docs/data/vizdoom/doom_calibrate.py``; ``docs/notebook/vizdoom.md``,
2026-11-27):

Pose quantisation
    ``warp X Y`` takes integers (``atoi``: ``warp 500.99 300.7`` lands on 500, 300), so the
    backend sends the nearest whole centimetre: over 500 random poses the engine's position is
    the asked one to within 0.4997 cm (half a unit). ``TURN_LEFT_RIGHT_DELTA`` turns clockwise
    by ``floor(delta * 65536 / 360)`` engine angle units (1/65536 turn = 0.0055 deg;
    ``20.0`` turns 3640 units = 19.9951 deg, ``0.004`` not at all); the backend sends whole
    units plus a quarter, so the heading is the asked one to within 0.002744 deg (half a
    unit): finer than the paper's "integer angle". The engine ignores turns in its first ~8
    tics; the backend waits 12 before the first teleport.
A frame right after a warp
    is not complete: in the warp's own tic the eye is 4 units above the floor
    (``CAMERA_POSITION_Z`` 4, every one of 59 frames differs from the next tic's); one tic later
    it is at 50 and a third tic changes nothing (0 of 59 frames differ). So a teleport runs 2
    tics (``settle_tics``); ``set_pose`` with 2 gives the frames of 3 (60 of 60 poses).
Projection
    Doom's horizontal field of view is 90 deg: ``fx = W / 2``; its pixels are not square:
    ``fy`` is about 1.19 ``fx`` (Doom's 320 x 200 shown at 4:3 would be 1.2). Calibrated against
    the converted geometry two ways: (a) silhouette edges of boxes against a saturated far wall,
    least squares over 1928 column and 510 row edges at 320 x 240: fx 161.3, cx 159.52,
    fy 189.2, cy 118.9 (residuals <= 1.24 px, with a +-0.23 px S-shaped pattern across the
    image: Doom clips wall edges through its angle tables); (b) the fraction of pixels whose
    converted depth-buffer value lies within one step of the exact z-depth cast with the
    candidate projection (house-1, 12 poses), best at fx = W / 2 (against 0.99 and 1.01 W / 2),
    fy = 190.4 at 320 x 240 (99.80 %; 187.2 .. 191.2 all >= 99.6 %) and 93.6 .. 94.0 at
    160 x 120, with the centre at ``(W / 2 - 0.5, H / 2 - 0.5)`` in navbench's integer pixel
    convention. Used: 320 x 240: fx 160, fy 190, c (159.5, 119.5); 160 x 120: fx 80, fy 94,
    c (79.5, 59.5) (:data:`~navbench.sim.doom.engine.DOOM_INTRINSICS`). Appendix A's
    f = 150, c = (160, 120) is the paper's approximation of the same camera.
Depth buffer
    8-bit per pixel, but ViZDoom scales its value by ``H / 480`` (``viz_depth.cpp``), so at
    320 x 240 it ends at 127 and at 160 x 120 at 63. It is linear in z-depth: least squares
    over house-1 (40 poses) gives ``z = 7.112 v + 11.109`` map units at 320 x 240 (one step
    7.1 cm) and ``z = 7.120 v + 8.754`` at 160 x 120 (the step is the same; the range is not):
    values at or above 127 (63) are saturated: farther than about 9.1 m (4.5 m), or a far
    floor or ceiling near the horizon that the engine writes with values up to 255; those
    pixels are invalid. The converted depth is within one step of the exact depth for 99.93 %
    of floor, 99.63 % of ceiling and 99.73 % of wall pixels at 320 x 240, and for 96.8 %,
    98.8 % and 99.1 % at 160 x 120. Pixels on a discontinuity (a 4-neighbour more than 3
    steps away: ``edge_steps``) are invalid too: that drops 0.7 % (1.5 %) of the pixels and
    raises the share within one step from 99.76 % to 99.90 % (98.55 % to 98.85 %). No
    sprites: a converted map holds only the player start.
Frames per second (house-1, ``reset(pose)`` with its frame converted, median of 7 x 200 on
    the shared 2-core machine; ``docs/data/vizdoom/fps.txt``): 631 at 320 x 240 and 3554 at
    160 x 120 under a load average of 6.7 (the pymunk Simulator's ``reset`` on the same poses,
    same run: 185 and 396). The machine's load moves these by 2x or more: earlier runs under
    loads of 8 to 14, with the engine also copying its sectors every tic (now off unless
    asked), gave 445 / 1918, 277 / 653 and 214 / 581. The engine is a process of its own.
Engine start (house-1, ``docs/data/vizdoom/episode_time.py``, load 4.7-5.5)
    a level's conversion and a new engine process took ~0.25 s (conversion 0.11-0.13 s, the
    process's ``init`` 0.12-0.14 s), 0.24-0.27 s of every episode the pipeline ran (an engine
    per episode). The conversion now runs once per level content in a process
    (:func:`~navbench.sim.doom.wad.cached_level_map`) and, inside
    :func:`~navbench.sim.doom.engine.reuse_engines` (the worker's chunk of episodes), a closed
    engine is reused with ``new_episode``: 4-5 ms, the same frames bit for bit.
"""
