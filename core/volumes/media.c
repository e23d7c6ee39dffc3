/* Homogeneous media: core/volumes/media.py's Media table, a ray's volume stack, Beer-Lambert and media emission.
 *
 * A ray's volume stack holds the media it is in, each once, and the order it entered them in (Media.start keeps each
 * medium's place per column, int16): per volume material, or per object where Media.of keeps it per object (its
 * graph reads the object's Object Info, its objects' boxes overlap, or it emits into different light groups:
 * Media.column_of, medium_column; Cycles' stack holds (object, shader) pairs): put last where the ray went through a
 * front face of its mesh, unless already there; taken off through a back face (Cycles' volume_stack_enter_exit).
 * What a stretch of the ray crosses is the world's medium plus each stacked medium. The stack is sparse, as Cycles'
 * is: a render may have any number of media (columns), a ray be in media->room of them at once (MAX_MEDIA = 31,
 * Cycles' MAX_VOLUME_STACK_SIZE 32 less its end marker; 30 where the world has a volume, whose entry Cycles' stack
 * holds too); a further one it enters is left out, as Cycles leaves out what its stack has no room for, and as the
 * Python reference's Media.enter does. */

/* A ray's volume stack (Media.start's row, its nonzero places): `size` media, their columns of the MediaTables in
 * increasing order (the order the dense row sums them in) and each one's place in the order the ray entered them
 * (1 .. the first; higher: entered later). */
typedef struct {
    int32_t column[MAX_MEDIA];
    int16_t place[MAX_MEDIA];
    int32_t size;
} VolumeStack;

/* Media.start: the stack of a ray in no mesh's medium. */
INLINE void stack_empty(VolumeStack *stack)
{
    stack->size = 0;
}

/* How many times a ray with stack `stack` is in the medium of column v: 1, else 0 (each medium once: stack_add). */
INLINE int stack_count(const VolumeStack *stack, int32_t v)
{
    for (int i = 0; i < stack->size; i++)
        if (stack->column[i] == v) return 1;
    return 0;
}

/* Media.enter (step +1) and Media.leave (step -1) for one stack and column v: entered, it is put last in the order
 * unless already there; left, it is taken off and the media entered after it move one place down; leaving a medium
 * the ray is not in changes nothing, and one more where the stack holds `room` (MediaTables.room, at most MAX_MEDIA)
 * is left out (Cycles: "exceed the stack limit, ignore"). */
INLINE void stack_add(VolumeStack *stack, int32_t v, int step, int64_t room)
{
    int i = 0;
    while (i < stack->size && stack->column[i] < v) i++;
    int here = i < stack->size && stack->column[i] == v;
    if (step > 0) {
        if (here || stack->size >= MAX_MEDIA || stack->size >= room) return;
        int16_t last = 0;
        for (int j = 0; j < stack->size; j++)
            if (stack->place[j] > last) last = stack->place[j];
        for (int j = stack->size; j > i; j--) {
            stack->column[j] = stack->column[j - 1];
            stack->place[j] = stack->place[j - 1];
        }
        stack->column[i] = v;
        stack->place[i] = (int16_t)(last + 1);
        stack->size++;
        return;
    }
    if (!here) return;
    int16_t gone = stack->place[i];
    for (int j = i; j + 1 < stack->size; j++) {
        stack->column[j] = stack->column[j + 1];
        stack->place[j] = stack->place[j + 1];
    }
    stack->size--;
    for (int j = 0; j < stack->size; j++)
        if (stack->place[j] > gone) stack->place[j]--;
}

/* lightgroups.LightGroups.emission_groups for one stack: the light group of the media's emission along a ray in it,
 * that of the medium it entered last (the highest place; Cycles: the object of its volume stack's last entry), else
 * world_group. */
INLINE int64_t emission_group(const MediaTables *media, const VolumeStack *stack, int64_t world_group)
{
    if (media->groups == NULL || stack == NULL || stack->size == 0) return world_group;
    int last = 0;
    for (int i = 1; i < stack->size; i++)
        if (stack->place[i] > stack->place[last]) last = i;
    return (int64_t)media->groups[stack->column[last]];
}

/* Media.along for one stack: the extinction sigma_t (3) and emission (3) of what the ray crosses, the world's plus
 * each medium's it is in (the media's sum first, then the world's, as Python adds). */
INLINE void medium_along(const MediaTables *media, const VolumeStack *stack, double *sigma_t, double *emission)
{
    double sigma[3] = {0.0, 0.0, 0.0}, e[3] = {0.0, 0.0, 0.0};
    for (int i = 0; i < stack->size; i++) {
        int64_t v = stack->column[i];
        double n = 1.0;                         /* (each medium once: stack_add) */
        for (int c = 0; c < 3; c++) {
            sigma[c] += n * media->sigma_t[3 * v + c];
            e[c] += n * media->emission[3 * v + c];
        }
    }
    for (int c = 0; c < 3; c++) {
        sigma_t[c] = media->world_sigma_t[c] + sigma[c];
        emission[c] = media->world_emission[c] + e[c];
    }
}

/* The scattering of a stretch's media (Media.along): sigma_s (3), the sigma_s-weighted mean anisotropy *g, and,
 * phase not NULL, the phase function: HG of *g where every medium that scatters there is HG, else that of the medium
 * that scatters most (the world first, then the columns in order, on a tie). */
INLINE void medium_scattering(const MediaTables *media, const VolumeStack *stack, double *sigma_s, double *g,
                              Phase *phase)
{
    double sum[3] = {0.0, 0.0, 0.0}, weighted = 0.0;
    const double *w = media->world_sigma_s;
    double world_share = (w[0] + w[1]) + w[2], best = world_share;
    int64_t first = -1;                                  /* (-1: the world) */
    int other = world_share > 0.0 && media->world_phase != PHASE_HENYEY_GREENSTEIN;
    for (int i = 0; i < stack->size; i++) {
        int64_t v = stack->column[i];
        double n = 1.0;                         /* (each medium once: stack_add) */
        const double *s = media->sigma_s + 3 * v;
        for (int c = 0; c < 3; c++) sum[c] += n * s[c];
        double share = n * ((s[0] + s[1]) + s[2]);
        weighted += n * (((s[0] + s[1]) + s[2]) * media->g[v]);
        if (share > 0.0 && media->phase[v] != PHASE_HENYEY_GREENSTEIN) other = 1;
        if (share > best) { best = share; first = v; }
    }
    double scattering = world_share * media->world_g + weighted;
    for (int c = 0; c < 3; c++) sigma_s[c] = w[c] + sum[c];
    double total = (sigma_s[0] + sigma_s[1]) + sigma_s[2];
    *g = total > 0.0 ? scattering / total : 0.0;
    if (phase == NULL) return;
    phase->lobes = 0;
    for (int k = 0; k < PHASE_PARAMETERS; k++) phase->p[k] = 0.0;
    phase->kind = PHASE_HENYEY_GREENSTEIN;
    phase->p[0] = *g;
    if (!other) return;
    phase->kind = first < 0 ? media->world_phase : media->phase[first];
    const double *numbers = first < 0 ? media->world_parameters : media->parameters + PHASE_PARAMETERS * first;
    for (int k = 0; k < PHASE_PARAMETERS; k++) phase->p[k] = numbers[k];
    if (phase->kind == PHASE_HENYEY_GREENSTEIN) phase->p[0] = first < 0 ? media->world_g : media->g[first];
}

/* volumes.transmittance (Beer-Lambert) over distance t (inf: a ray that escapes) through extinction sigma_t (3):
 * T (3) = exp(-sigma_t t), 1 where sigma_t is 0 whatever the distance. */
INLINE void beer_lambert(const double *sigma_t, double t, double *T)
{
    for (int c = 0; c < 3; c++) T[c] = sigma_t[c] > 0.0 ? exp(-sigma_t[c] * t) : 1.0;
}

/* volumes.emitted: the light (3) a medium of extinction sigma_t (3) and emission e (3) sends along a ray over
 * distance t (inf: to the world), as it arrives at the ray's start: e (1 - exp(-sigma_t t)) / sigma_t, e t where
 * nothing is in the way, 0 where nothing is emitted; added to out. */
INLINE void add_media_emission(const double *sigma_t, const double *e, double t, double *out)
{
    for (int c = 0; c < 3; c++) {
        if (e[c] == 0.0) continue;
        out[c] += sigma_t[c] > 0.0 ? e[c] * -expm1(-sigma_t[c] * t) / sigma_t[c] : e[c] * t;
    }
}

/* Media.column_of for one surface of material row `material` on object `object` (Scene.instances, -1: none): the
 * column of the medium it bounds (its material's, or that object's where the material keeps media per object), or
 * -1 where it bounds none. */
INLINE int32_t medium_column(const MediaTables *media, int64_t material, int64_t object)
{
    int32_t k = media->keyed[material];
    if (k < 0) return media->column[material];
    return object < 0 ? -1 : media->object_column[(int64_t)k * media->objects + object];
}

/* Media.crossed for one ray that goes through (crossing) surface s: into the medium it bounds (medium_column)
 * through a front face, out of it through a back face (never below 0); no change where it bounds none. */
INLINE void stack_cross(const MediaTables *media, VolumeStack *stack, const Surface *s, int crossing)
{
    int32_t v = medium_column(media, s->material, s->object);
    int backfacing = s->backfacing;
    if (!crossing || v < 0) return;
    stack_add(stack, v, backfacing ? -1 : 1, media->room);
}

/* A shadow ray's stack from the stack it starts in: without the media shadow rays pass (Media.shadowless). */
INLINE VolumeStack shadow_stack(const MediaTables *media, const VolumeStack *stack)
{
    VolumeStack shadow;
    shadow.size = 0;
    for (int i = 0; i < stack->size; i++) {
        if (media->shadowless[stack->column[i]]) continue;
        shadow.column[shadow.size] = stack->column[i];
        shadow.place[shadow.size++] = stack->place[i];
    }
    return shadow;
}

/* Whether material row `material` is a volume-only boundary (rays pass it without counting a transparent bounce). */
INLINE int is_boundary(const MediaTables *media, int64_t material)
{
    return media != NULL && media->boundary[material] != 0;
}

/* Whether `object` is among the first `n` of `objects`. */
INLINE int object_among(const int64_t *objects, int n, int64_t object)
{
    for (int i = 0; i < n; i++)
        if (objects[i] == object) return 1;
    return 0;
}

/* rays.camera_media for one camera ray from O (on the near clip plane): the stack it starts in, by Cycles'
 * integrator_volume_stack_init (rays._walk). From O straight up (WALK_UP: world +z, whatever way the ray looks) past
 * every surface (CAMERA_MEDIA_HITS at most), meeting only objects camera rays see: a front face of a medium's surface
 * marks its object entered; a back face of an object neither entered on the way nor taken already puts its medium
 * on the stack, last (nearest first, each object once); past VOLUME_WALK_HITS surfaces with a medium the walk stops.
 * A ray from outside the box of the media's triangles starts in none. */
static void camera_media(const MediaTables *media, const GeometryTables *geometry, Intersect8 intersect, void *scene,
                         const double *O, VolumeStack *stack)
{
    stack_empty(stack);
    if (media->count == 0) return;
    for (int c = 0; c < 3; c++)
        if (!(O[c] >= media->low[c] && O[c] <= media->high[c])) return;
    int64_t entered[VOLUME_WALK_HITS], taken[VOLUME_WALK_HITS];
    int n_entered = 0, n_taken = 0, counted = 0;
    const double D[3] = {0.0, 0.0, 1.0};
    double P[3] = {O[0], O[1], O[2]};
    for (int step = 0; step < CAMERA_MEDIA_HITS && counted < VOLUME_WALK_HITS; step++) {
        /* a. The next surface up. */
        RayHitPacket packet;
        int valid[PACKET] ALIGNED(32);
        set_lane(&packet.ray, 0, P, D, INFINITY);
        close_packet(&packet.ray, valid, 1);
        clear_hits(&packet);
        intersect(valid, scene, &packet, NULL);
        if (packet.hit.geomID[0] == INVALID_ID) return;
        Triangle tri = {{0.0}, {0.0}, {0.0}, 0, 0, 0.0, -1};
        hit_triangle(geometry, (int64_t)packet.hit.geomID[0], (int64_t)packet.hit.primID[0],
                     instance_of(&packet.hit, 0), 0, STILL_TIME, &tri);   /* (a render with media moves no object) */
        Surface s;
        surface_at(P, D, (double)packet.ray.tfar[0], (double)packet.hit.u[0], (double)packet.hit.v[0], &tri, 0, &s);
        /* b. A front face marks its object entered; a back face of an object neither entered nor taken: a medium the
         * ray started in. (An object camera rays do not see is not there.) */
        int32_t v = medium_column(media, s.material, s.object);
        if (v >= 0 && s.object >= 0 && geometry->hidden != NULL && (geometry->hidden[s.object] & HIDDEN_FROM_CAMERA))
            v = -1;
        if (v >= 0) {
            if (!s.backfacing) entered[n_entered++] = s.object;
            else if (!object_among(entered, n_entered, s.object) && !object_among(taken, n_taken, s.object)) {
                int before = stack->size;
                stack_add(stack, v, 1, media->room);    /* (last, unless the stack is full or holds v) */
                if (stack->size > before) taken[n_taken++] = s.object;
            }
            counted++;
        }
        /* c. On from just past it (shadows.spawn_ray: off the surface along Ng, on the side D goes to). */
        double side = dot3(s.Ng, D) < 0.0 ? -1.0 : 1.0;
        for (int c = 0; c < 3; c++) P[c] = s.I[c] + (s.offset * side) * s.Ng[c];
    }
}
