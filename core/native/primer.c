/* Primer's compiled library: every part's C file, in the order they build on each other.
 *
 * One translation unit, so that the compiler can inline a light's sampling or a BSDF into the
 * integrator's loops. Each file is the compiled twin of the Python beside it; adding a light type
 * or a BSDF means one C file here and one entry in its part's table (core/lights/lights.c,
 * core/materials/bsdf.c). Built by tools/build_kernels.py (`make kernels`), loaded by
 * core/native/library.py. */
#include "primer.h"

#define PRIMER_ABI 34

#include "../sampling/sobol.c"
#include "../camera/camera.c"
#include "../geometry/embree.c"
#include "../geometry/triangles.c"
#include "../lights/lights.h"
#include "../lights/point.c"
#include "../lights/spot.c"
#include "../lights/sun.c"
#include "../lights/area.c"
#include "../lights/emitters.c"
#include "../lights/world.c"
#include "../lights/lights.c"
#include "../materials/bsdf.h"
#include "../materials/lambert.c"
#include "../materials/mirror.c"
#include "../materials/thin_film.c"
#include "../materials/microfacet.c"
#include "../materials/glass.c"
#include "../materials/transparent.c"
#include "../materials/rough_glass.c"
#include "../materials/oren_nayar.c"
#include "../materials/sheen.c"
#include "../materials/velvet.c"
#include "../materials/bsdf.c"
#include "../materials/textures.c"
#include "../materials/graph.c"
#include "../materials/nodes.c"
#include "../film/film.c"
#include "../film/adaptive.c"
#include "../integrators/shadows.c"
#include "../integrators/lightpasses.c"
#include "../integrators/direct.c"
#include "../integrators/path.c"
#include "../integrators/chunk.c"

/* The interface version core/native/library.py checks (its ABI). */
EXPORT int64_t primer_abi(void) { return PRIMER_ABI; }
EXPORT int64_t primer_shadow_settings_size(void) { return (int64_t)sizeof(ShadowSettings); }
