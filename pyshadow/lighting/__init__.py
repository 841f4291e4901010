"""Lighting: environment maps, spherical harmonics, skies without files, the sun.

Frame (as everywhere in pyshadow): right-handed, y up, directions
``d(theta, phi) = (sin theta cos phi, cos theta, sin theta sin phi)`` pointing
from the scene towards the light; ``theta = arccos(y)``, ``phi = atan2(z, x)``.

- :class:`EnvironmentMap` (:mod:`~pyshadow.lighting.envmap`): lat-long
  (equirectangular) maps and cube maps read from any HDR file OpenImageIO
  reads (lat-long, horizontal or vertical cube cross) or from arrays; exact
  per-texel solid angles; ``sh()`` -> (9, 3) coefficients; irradiance by
  Ramamoorthi and Hanrahan's 9-coefficient formula.
- :mod:`~pyshadow.lighting.sh`: the real SH basis of order 3 and its mapping
  to ``scipy.special`` (signs and axes).
- :mod:`~pyshadow.lighting.cube`: face frames and cross layouts.
- :func:`clear_sky` (Preetham et al. 1999), :func:`overcast_sky` (CIE),
  :func:`sun_position` (:mod:`~pyshadow.lighting.sky`): luminance-scaled RGB in
  cd/m^2.
- :func:`extract_sun` (:mod:`~pyshadow.lighting.sun`): a :class:`SunLight`
  plus the sky without it, exactly energy-conserving.
- :class:`Lighting`, :func:`shade` (:mod:`~pyshadow.lighting.shade`): a sky
  as SH, a sun with its shadow, albedos -> linear RGB radiance of surface
  points through any visibility backend ("bent": the irradiance at the bent
  normal times AO; "transfer": the shadowed SH transfer of
  :mod:`~pyshadow.lighting.transfer`; "sampled": the map's radiance per AO
  sample direction times its visibility); what
  ``pyshadow.render.render(..., lighting=)`` puts in ``Frame.radiance``.
- :class:`PointLight`, :class:`SpotLight`, :func:`point_light_radiance`
  (:mod:`~pyshadow.lighting.local`): point, sphere and spot lights with their
  shadows through finite shadow rays, in the sun's irradiance units.
- :class:`DiscLight`, :class:`RectLight`, :func:`area_light_radiance`
  (:mod:`~pyshadow.lighting.area`): one-sided area lights with soft shadows,
  area-sampled, in the point lights' units.
- :class:`PhongLighting`, :func:`phong_shade` (:mod:`~pyshadow.lighting.phong`):
  thesis 000 eq. 3.2 (point light, Phong specular, AO-weighted, constant or
  normal-sample ambient); display-referred, not added to :class:`Lighting`'s radiance.
- :class:`ShadowMapVisibility` (:mod:`~pyshadow.lighting.shadow_map`): the
  classic scene shadow map (orthographic for a sun, a cube map for a point
  light) re-rendered when bodies move, with a depth bias and PCF; a
  visibility backend for light rays, the baseline the CSM is compared with.
- :func:`reference_radiance` (:mod:`~pyshadow.lighting.reference`): the same
  integrals converged through Embree, the ground truth of every mode.
- :func:`tonemap`, :func:`auto_exposure`, :func:`write_radiance` (:mod:`~pyshadow.lighting.tonemap`):
  8-bit display values (sRGB or thesis 001's exponential curve; ``exposure="auto"``), EXR or HDR output.
"""
from . import cube, sh
from .envmap import EnvironmentMap, latlong_directions, latlong_solid_angles
from .sh import irradiance_sh, sh_basis
from .sky import (SUN_ANGULAR_RADIUS, add_sun_disc, clear_sky, disc_solid_angle, overcast_sky,
                  sun_irradiance, sun_position)
from .sun import SunLight, extract_sun
from .shade import (SAMPLED_SUN_SAMPLES, DirectionalLight, Lighting, ShadedPoints, sampled_sky_radiance, shade,
                    shade_terms, transfer_sky_radiance)
from .transfer import sh_transfer, transfer_irradiance
from .reference import reference_radiance
from .local import PointLight, SpotLight, point_light_radiance
from .area import DiscLight, RectLight, area_light_radiance, area_light_samples
from .phong import PhongLighting, phong_shade
from .shadow_map import ShadowMapVisibility
from .tonemap import auto_exposure, tonemap, write_radiance

__all__ = ["DiscLight", "PhongLighting", "RectLight", "ShadowMapVisibility", "area_light_radiance",
           "area_light_samples", "phong_shade",
           "DirectionalLight", "EnvironmentMap", "Lighting", "SAMPLED_SUN_SAMPLES", "ShadedPoints", "SunLight",
           "SUN_ANGULAR_RADIUS", "add_sun_disc", "clear_sky", "cube", "disc_solid_angle",
           "extract_sun", "irradiance_sh", "latlong_directions", "latlong_solid_angles",
           "overcast_sky", "PointLight", "SpotLight", "point_light_radiance", "reference_radiance",
           "sampled_sky_radiance", "sh", "sh_basis", "sh_transfer", "shade",
           "shade_terms", "sun_irradiance", "sun_position", "tonemap", "auto_exposure", "transfer_irradiance",
           "transfer_sky_radiance", "write_radiance"]
