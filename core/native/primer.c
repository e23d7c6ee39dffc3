/* Primer's compiled library: every part's C file, in the order they build on each other.
 *
 * One translation unit, so that the compiler can inline a light's sampling or a BSDF into the
 * integrator's loops. Each file is the compiled twin of the Python beside it; a light type's or a
 * BSDF's C file is included by its part's generated table (core/lights/lights.gen.c,
 * core/materials/bsdfs.gen.c), written by tools/make_boundary.py from the Python tables. Built by
 * tools/build_kernels.py (`make kernels`), loaded by core/native/library.py. */
#include "primer.h"
#include "boundary.gen.h"               /* constants, tables and records from the Python (tools/make_boundary.py) */

#include "../sampling/sobol.c"
#include "../camera/camera.c"
#include "../geometry/embree.c"
#include "../geometry/triangles.c"
#include "../volumes/phase.c"           /* the phase functions (media.c, volume.c; HG: subsurface.c) */
#include "../volumes/media.c"           /* homogeneous media: the volume stack, Beer-Lambert, media emission */
#include "../lights/lights.h"
#include "../materials/ies.c"          /* IES light profiles: Cycles' reading and interpolation (lamps and node graphs) */
#include "../lights/ies.c"             /* a lamp's IES Texture in the lamp's frame */
#include "../lights/lights.c"           /* every light's C file, through the generated table lights.gen.c */
#include "../materials/bsdf.h"
#include "../materials/tables.c"        /* the GGX albedo tables and the lookups of every table */
#include "../materials/thin_film.c"
#include "../materials/bsdf.c"          /* every BSDF's C file, through the generated table bsdfs.gen.c */
#include "../materials/textures.c"
#include "../materials/procedural/procedural.gen.c"   /* the procedural textures' C files (tools/make_boundary.py) */
#include "../materials/converters/converters.gen.c"   /* the converter and colour nodes' C files (tools/make_boundary.py) */
#include "../materials/sky.c"           /* the Sky Texture's op (graph.c calls it) */
#include "../materials/sky_tables.c"    /* the scattering skies' tables (core/materials/sky.py calls them) */
#include "../materials/graph.c"
#include "../materials/nodes.c"
#include "../lights/world_graph.c"       /* the world's program, per texel of its bake and per camera ray */
#include "../lights/lamp_graph.c"        /* a lamp's node tree, per light sample and per ray that meets it */
#include "../volumes/field.c"           /* heterogeneous media: a volume graph run at points, the march along a ray */
#include "../film/film.c"
#include "../film/adaptive.c"
#include "../integrators/shadows.c"
#include "../integrators/shader_rays.c"  /* the rays Ambient Occlusion and Bevel nodes trace (graph.c calls them) */
#include "../integrators/subsurface.c"   /* the subsurface random walk inside a mesh (direct.c calls it) */
#include "../integrators/lightpasses.c"
#include "../integrators/direct.c"
#include "../integrators/mnee.c"          /* shadow caustics: the manifold walk for one light sample (direct.c calls it) */
#include "../integrators/features.c"
#include "../integrators/passes.c"
#include "../integrators/path.c"
#include "../integrators/volume.c"      /* scattering along the paths' rays, Volume Bounces' chains */
#include "../integrators/chunk.c"
#include "exports.gen.c"               /* what Python calls: one record of arguments each (tools/make_boundary.py) */
