"""Participating media: light absorbed (and, later slices, scattered and emitted) along the way between surfaces.

A homogeneous medium has the same coefficients at every point: sigma_a (absorption) and sigma_s (scattering) per
unit length, per colour channel, and sigma_t = sigma_a + sigma_s (extinction). Light that crosses a distance t
through it keeps the share

    T(t) = exp(-sigma_t t)          (Beer-Lambert)

per channel. A medium fills the inside of a closed mesh whose material has a Volume output (entered through a front
face, left through a back face: Cycles' volume stack, `Media.crossed`), or all space where the world has one.

- `media.py`: the volume closures as classes with their flags (Volume Absorption, Volume Scatter, Principled
  Volume, Volume Coefficients, an Emission node at a Volume output), read into one `Media` table per render: each volume material's coefficients, and the world's.
  `Media.crossed` keeps which media a ray is in, each once and in the order entered (per volume material, or per
  object where the material's volume graph reads Object Info, its objects overlap or it emits into several light
  groups: `Media.column_of`, `split_by_object`), `transmittance` what it lets through.
  `Media.tables` packs them for the compiled kernel's twin, `media.c` (the volume stack, Beer-Lambert, emission).
- `phase.py`: phase functions, the volume's BSDF: the Phase menu's Henyey-Greenstein, Fournier-Forand, Draine,
  Rayleigh and Mie, each with eval, sample, pdf and its mean cosine; a medium carries one as a kind and four numbers.
- `field.py`: heterogeneous media: a Volume output whose inputs are fed by nodes (`Field`, its node graph run at
  points inside the medium; the world's, `media.world_field_of`, unbounded, every ray in it), and the march of a ray through them (`March`: pieces of constant coefficients, on
  which Beer-Lambert, emission and free flight hold piece by piece); its compiled twin `field.c` runs each Field's
  program at points (its `VolumeField` record, chained from `MediaTables.fields`) and marches rays the same way.
"""
from .media import (ABSORPTION, Coefficients, Media, PrincipledVolume, VolumeAbsorption, VolumeClosure, VolumeFlags,
                    VolumeCoefficients, VolumeEmission, VolumeScatter, VOLUME_BY_BLENDER, VOLUME_BY_NAME, VOLUME_TYPES)
from .phase import Draine, FournierForand, HenyeyGreenstein, Mie, Phases, Rayleigh
from .field import VolumeFieldRecord
from .media import MAX_MEDIA, MediaTablesRecord, Stretch, emitted, transmittance

__all__ = ["ABSORPTION", "Coefficients", "Draine", "FournierForand", "HenyeyGreenstein", "Mie", "Phases", "Rayleigh", "Media", "PrincipledVolume", "VolumeAbsorption", "VolumeClosure",
           "VolumeCoefficients", "VolumeEmission", "VolumeFlags", "VolumeScatter", "VOLUME_BY_BLENDER", "VOLUME_BY_NAME", "VOLUME_TYPES", "MAX_MEDIA", "MediaTablesRecord", "VolumeFieldRecord", "Stretch", "emitted", "transmittance"]
