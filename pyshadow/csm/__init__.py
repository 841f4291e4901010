"""Coherent Shadow Maps: the data, its streaming builder, device layout, file format and NumPy mirrors.

Stage "compress" of the pipeline (thesis 000, sections 4.2.1, 5.2.1-5.2.3;
Ritschel et al. 2007).

For every texel ``t`` the maps are visited in view-set order ``i = 0..D-1``.
Map ``i`` allows a set of stored depths that still gives the right shadow
test along the texel's ray:

* hit at least twice: ``[z1, z2)`` less a slope term before ``z2``: how much
  nearer than ``z2`` its surface comes within the texel (half the larger
  step nearer to a neighbour texel's ``z2`` on each axis, at most
  ``FRONT_MARGIN_TEXELS`` texels) plus ``SLOPE_SLACK_QUANTA`` quanta, so
  that points on that surface anywhere in the texel (the ground under a
  closed body, a body touching its back) stay in shadow wherever it comes
  at most ``FRONT_MARGIN_TEXELS`` texels nearer over half a texel (a flat
  ``z2``: maps more than atan(sqrt(2)/6) = 13.3 degrees above it; lower
  ones may light it); where the surface at ``z2`` faces the light (a second
  sheet of an open mesh, in the first one's shadow; by default also where
  it is the back of a face open to the outside, such as an open box's inner
  floor (:mod:`.exposure`: 1.0-1.07x the bytes on the bundled open meshes;
  every ``z2`` with ``two_sided=True``: 1.4-1.5x) a margin of
  ``FRONT_MARGIN_TEXELS`` texels more; just ``z1`` when that leaves
  nothing; with ``layers=3`` up to ``z3`` less the margin
  where the ray leaves the object at ``z2`` and re-enters at ``z3``, see
  :meth:`CoherentShadowMap.build`. The margin exists because such a surface
  is asked with a self-bias (1.5 texels by default, see
  :meth:`pyshadow.Scene.visible`): a stored depth within the bias of it
  would light it;
* free space behind ``z1``: where ``z1`` does not face the light (a room's
  wall seen from outside), or ``z2`` faces the light or is a back open to
  the outside on a mesh that is mostly open (a bowl's far wall across its
  hollow; :func:`open_sheet`), or ``two_sided=True``, the interval also
  ends ``z1``'s slope term behind ``z1`` (how much deeper its surface goes
  within the texel, at most ``FRONT_MARGIN_TEXELS`` texels:
  :func:`first_slope`), so points in that
  space -- a ball in the bowl, anything inside the room -- stay in shadow
  (before: a ball in a bowl read 36 % of its AO rays wrong;
  benchmarks/README.md, "Free space inside a caster");
* hit once (a hole behind the first surface): only ``z1``;
* missed: only ``+inf`` (a miss meets nothing but other misses).

A run of consecutive maps whose sets still intersect is stored as one segment
``(z, i_end)`` with ``z`` inside the intersection and ``i_end`` the run's last
map; greedy extension gives the fewest segments for the order. Per texel the
segments are sorted by ``i_end``; ``offsets[t] .. offsets[t+1]`` is texel
``t``'s list. The build streams: a block of maps is rendered, folded into the
per-texel run state on the device and dropped, so memory does not grow with
the number of maps.

Layer rules (``layers`` of :meth:`CoherentShadowMap.build`): which surfaces
bound a map's interval of valid depths.

* ``2``: ``[z1, z2)`` -- every shadow query along a texel's ray is exact (up
  to the depth quantum and the map discretisation), for points anywhere: on
  this object, on other objects, on the ground -- on a closed mesh wound
  outwards. Where the ray runs through free space behind ``z1`` (above) the
  interval ends near ``z1``, so a point in the air between two sheets
  (inside an open box, say) stays in shadow unless it lies within that
  slope term of ``z1``. On a mesh that is mostly closed (less than half its
  area open at the back, such as the bunny with its holes) a point in the
  air inside it, reached through an opening, may be reported lit, as may
  one between two sheets with ``two_sided=False``. Points on the second
  sheet where it faces the light (every
  ``z2`` with ``two_sided``) stay in shadow: the interval ends ``m`` (below)
  more before it, or is ``z1``. All end z2's slope term before it.
* ``3``: ``[z1, z3 - m)`` with ``m = FRONT_MARGIN_TEXELS / R`` (3 texels of
  depth) where the texel's ray leaves the object at ``z2`` and re-enters it
  at ``z3`` and ``z3 - m > z2``, ``[z1, z2)`` elsewhere; closed meshes only
  (the freedom of Ritschel et al.; thesis 4.2.1, footnote 2), and not
  where the ray runs through free space behind ``z1`` (a room). Fewer
  segments. Exact for points on this object's own surface whose normal faces
  the light, tested with a self-bias up to ``m`` (the back face at ``z2`` is
  never asked: its hemisphere excludes the light; the default self-bias of
  :meth:`pyshadow.Scene.visible` is 1.5 texels plus an angle term), and for
  every other point except those inside a concavity of the object along the
  ray, between its exit ``z2`` and re-entry ``z3``: such a point (on another
  body, say, tucked under an arch of this one) may be reported lit where it
  is in shadow. The margin keeps a stored depth out of the self-bias of
  ``z3``, so the re-entry surface stays in shadow. The stored depth is taken
  inside ``[z1, z2)`` of every map of the run whenever that is possible. What
  the margin and the rule cost and buy is measured in benchmarks/README.md.
* ``'auto'``: 3 for watertight meshes, else 2.

Depth storage: 16 bit fixed point ``k / 65534`` (``k = 65535`` is a miss) or
32 bit float (``+inf`` a miss). Quantised values obey the same rule: each
map's set becomes a set of integer keys (``[ceil(z1*Q), ceil(z2*Q) - 1]``)
and runs intersect those exactly, so a stored 16-bit depth always lies inside
the interval of every map of its run -- except where a single map's
``[z1, z2)`` holds no quantum at all (surfaces closer than 1/65534); such a
map stands alone with the smallest quantum at or above ``z1``.

The package, one module a job: :mod:`.core` (:class:`CoherentShadowMap`, the
arrays and their decoding), :mod:`.build` (the streaming builder),
:mod:`.device` (search arrays and the scene atlas of the kernels),
:mod:`.fileformat` (``.csm`` save, load, validation), :mod:`.reference`
(NumPy mirrors of the kernels), :mod:`.error_model` (a CSM's disagreement
with a ray tracer, predicted before it is built), :mod:`.choose`
(parameters from the accuracy asked for, or the most accurate within a size),
:mod:`.exposure` (the faces whose back side the build keeps in shadow too).
"""
from .core import (DEPTH_Q, FRONT_MARGIN_TEXELS, MISS16, SEARCH_BLOCK, SLOPE_SLACK_QUANTA, CoherentShadowMap,
                   CSMFormatError, front_margin, slope_slack)
from .build import corner_frame, footprint_corners, footprint_scale
from .fileformat import FORMAT_VERSION, MAGIC
from .reference import (compress_reference, first_slope, footprint_interval, map_intervals, second_bound, second_slope,
                        shadow_vote)
from .choose import choose_csm, choose_within
from .exposure import both_sided_faces, escape_fractions, exposed_back_faces, open_sheet
from . import build, choose, core, device, error_model, exposure, fileformat, reference

__all__ = ["CoherentShadowMap", "CSMFormatError", "DEPTH_Q", "MISS16", "SEARCH_BLOCK", "FRONT_MARGIN_TEXELS",
           "SLOPE_SLACK_QUANTA", "FORMAT_VERSION", "MAGIC", "compress_reference", "front_margin", "slope_slack",
           "first_slope", "second_bound", "second_slope", "corner_frame",
           "footprint_corners", "footprint_interval", "footprint_scale", "map_intervals", "shadow_vote",
           "choose_csm", "choose_within", "both_sided_faces", "escape_fractions", "exposed_back_faces",
           "open_sheet",
           "build", "choose", "core", "device", "error_model", "exposure", "fileformat", "reference"]
