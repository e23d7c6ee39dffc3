/* Ray queries in packets: core/geometry/intersect.py's Tracer, through Embree's rtcIntersect8 / rtcOccluded8.
 *
 * Embree 4's packet records (rtcore_ray.h), 8 rays wide, structure of arrays. Embree reads the fields
 * in this order; the hit's instance fields are sized for one instance level with instance arrays
 * (RTC_MAX_INSTANCE_LEVEL_COUNT 1), which is how embreex's Embree is built (tests/test_intersect.py
 * compares every answer with embreex's own queries). The spare rows keep an Embree built for more
 * levels from writing past the record; nothing here reads them. */

#define PACKET 8
typedef struct {
    float org_x[PACKET], org_y[PACKET], org_z[PACKET], tnear[PACKET];
    float dir_x[PACKET], dir_y[PACKET], dir_z[PACKET], time[PACKET];
    float tfar[PACKET];
    uint32_t mask[PACKET], id[PACKET], flags[PACKET];
} ALIGNED(32) RayPacket;

typedef struct {
    float Ng_x[PACKET], Ng_y[PACKET], Ng_z[PACKET];
    float u[PACKET], v[PACKET];
    uint32_t primID[PACKET], geomID[PACKET];
    uint32_t instID[1][PACKET];
    uint32_t instPrimID[1][PACKET];
    uint32_t spare[14][PACKET];
} ALIGNED(32) HitPacket;

typedef struct { RayPacket ray; HitPacket hit; } RayHitPacket;

/* Embree's functions, passed in as addresses by core/geometry/intersect.py (the library embreex loaded). */
typedef void (*Occluded8)(const int *valid, void *scene, RayPacket *ray, void *arguments);
typedef void (*Intersect8)(const int *valid, void *scene, RayHitPacket *rayhit, void *arguments);

#define INVALID_ID 0xFFFFFFFFu

/* Lane k of a packet: a ray from origin o along d up to t (float64, rounded to Embree's float32 here,
 * t clamped to its "infinite" first). */
INLINE void set_lane(RayPacket *ray, int k, const double *o, const double *d, double t)
{
    ray->org_x[k] = (float)o[0]; ray->org_y[k] = (float)o[1]; ray->org_z[k] = (float)o[2];
    ray->dir_x[k] = (float)d[0]; ray->dir_y[k] = (float)d[1]; ray->dir_z[k] = (float)d[2];
    ray->tnear[k] = 0.0f;
    ray->time[k] = 0.0f;
    ray->tfar[k] = t < (double)T_INFINITY ? (float)t : T_INFINITY;
    ray->mask[k] = INVALID_ID;
    ray->id[k] = 0;
    ray->flags[k] = 0;
}

/* The time of rays in a scene where nothing moves (and of media's rays: a render with media blurs no object). */
static const double STILL_TIME = 0.0;

/* Lane k's time in the shutter, 0 to 1 (object motion blur: where a moving instance is; a still scene ignores it). */
INLINE void set_time(RayPacket *ray, int k, double time)
{
    ray->time[k] = (float)time;
}

/* Switch lanes `lanes` .. PACKET - 1 off, as copies of lane 0 (Embree reads every lane's fields). */
INLINE void close_packet(RayPacket *ray, int *valid, int lanes)
{
    for (int k = 0; k < PACKET; k++) valid[k] = k < lanes ? -1 : 0;
    for (int k = lanes; k < PACKET; k++) {
        ray->org_x[k] = ray->org_x[0]; ray->org_y[k] = ray->org_y[0]; ray->org_z[k] = ray->org_z[0];
        ray->dir_x[k] = ray->dir_x[0]; ray->dir_y[k] = ray->dir_y[0]; ray->dir_z[k] = ray->dir_z[0];
        ray->tnear[k] = 0.0f; ray->time[k] = 0.0f; ray->tfar[k] = ray->tfar[0];
        ray->mask[k] = INVALID_ID; ray->id[k] = 0; ray->flags[k] = 0;
    }
}

/* A nearest-hit packet's hit fields set to "none". */
INLINE void clear_hits(RayHitPacket *packet)
{
    for (int k = 0; k < PACKET; k++) {
        packet->hit.geomID[k] = INVALID_ID;
        packet->hit.primID[k] = INVALID_ID;
        packet->hit.instID[0][k] = INVALID_ID;
        packet->hit.instPrimID[0][k] = INVALID_ID;
    }
}

/* Which placement of an instance array lane k hit (Embree's instPrimID), or -1 off any instance. */
INLINE int64_t instance_of(const HitPacket *hit, int k)
{
    return hit->instID[0][k] != INVALID_ID && hit->instPrimID[0][k] != INVALID_ID ? (int64_t)hit->instPrimID[0][k] : -1;
}

/* Whether anything lies on each ray within (0, t_max): Tracer.occluded.
 * origins, directions (n, 3), t_max (n,) float32 -> blocked (n,) uint8. Embree marks an occluded ray
 * by setting its tfar to -inf, as embreex reads it. */
static void occluded_rays(const OccludedArgs *a)
{
    Occluded8 occluded8 = (Occluded8)a->function;
    RayPacket ray;
    int valid[PACKET] ALIGNED(32);
    for (int64_t first = 0; first < a->n; first += PACKET) {
        int lanes = a->n - first < PACKET ? (int)(a->n - first) : PACKET;
        for (int k = 0; k < lanes; k++) {
            const float *origin = a->origins + 3 * (first + k), *direction = a->directions + 3 * (first + k);
            double o[3] = {origin[0], origin[1], origin[2]};
            double d[3] = {direction[0], direction[1], direction[2]};
            set_lane(&ray, k, o, d, (double)a->t_max[first + k]);
            if (a->time != NULL) set_time(&ray, k, a->time[first + k]);
        }
        close_packet(&ray, valid, lanes);
        occluded8(valid, a->scene, &ray, NULL);
        for (int k = 0; k < lanes; k++) a->blocked[first + k] = ray.tfar[k] < 0.0f;
    }
}

/* The nearest hit in (0, t_max) of each ray: Tracer.intersect.
 * origins, directions (n, 3), t_max (n,) float64 (rounded to float32 here) -> t (n,) float64 (inf where
 * missed), prim (n,) int64 (-1 where missed), geometry (n,) int32 Embree's geomID (-1 where missed),
 * u, v (n,) float64, instance (n,) int64 the placement hit in an instance array (-1: a copied triangle). */
static void intersect_rays(const IntersectArgs *a)
{
    Intersect8 intersect8 = (Intersect8)a->function;
    RayHitPacket packet;
    int valid[PACKET] ALIGNED(32);
    for (int64_t first = 0; first < a->n; first += PACKET) {
        int lanes = a->n - first < PACKET ? (int)(a->n - first) : PACKET;
        for (int k = 0; k < lanes; k++)
            set_lane(&packet.ray, k, a->origins + 3 * (first + k), a->directions + 3 * (first + k),
                     a->t_max[first + k]);
        if (a->time != NULL)
            for (int k = 0; k < lanes; k++) set_time(&packet.ray, k, a->time[first + k]);
        close_packet(&packet.ray, valid, lanes);
        clear_hits(&packet);
        intersect8(valid, a->scene, &packet, NULL);
        for (int k = 0; k < lanes; k++) {
            int64_t i = first + k;
            int hit = packet.hit.geomID[k] != INVALID_ID;
            a->t[i] = hit ? (double)packet.ray.tfar[k] : INFINITY;
            a->prim[i] = hit ? (int64_t)packet.hit.primID[k] : -1;
            a->geometry[i] = hit ? (int32_t)packet.hit.geomID[k] : -1;
            a->u[i] = hit ? (double)packet.hit.u[k] : 0.0;
            a->v[i] = hit ? (double)packet.hit.v[k] : 0.0;
            a->instance[i] = hit ? instance_of(&packet.hit, k) : -1;
        }
    }
}
