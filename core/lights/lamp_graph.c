/* A lamp's node tree per light sample and per ray that meets it: core/lights/lamp_graph.py. Its program (graph.c
 * run_program) run at the lamp's shading point as Cycles' shader_setup_from_sample sets it up. */

/* LampEmission.normal: an area lamp's normal, a sphere's outward normal (no Soft Falloff), else `leaving` (a sun's). */
INLINE void lamp_graph_normal(const LightRecord *light, const LampGraph *g, const double *P, const double *leaving,
                              double *N)
{
    if (light->kind == LIGHT_AREA) {
        for (int c = 0; c < 3; c++) N[c] = light->direction[c];
    } else if (g->sphere != 0 && g->uv_kind != UV_SUN) {
        double d[3] = {P[0] - light->position[0], P[1] - light->position[1], P[2] - light->position[2]};
        double length = sqrt(dot3(d, d));
        for (int c = 0; c < 3; c++) N[c] = length > 0.0 ? d[c] / length : 0.0;
    } else {
        for (int c = 0; c < 3; c++) N[c] = leaving[c];
    }
}

/* M^-1 v (row-major M^-1: g->inverse). */
INLINE void lamp_graph_local(const LampGraph *g, const double *v, double *out)
{
    const double *A = g->inverse;
    for (int i = 0; i < 3; i++) out[i] = (A[3 * i] * v[0] + A[3 * i + 1] * v[1]) + A[3 * i + 2] * v[2];
}

/* LampEmission.uv: the lamp's UV (z 0) at P with normal N and leaving direction `leaving`. */
INLINE void lamp_graph_uv(const LightRecord *light, const LampGraph *g, const double *P, const double *N,
                          const double *leaving, double *uv)
{
    uv[2] = 0.0;
    if (g->uv_kind == UV_SUN) {                         /* Cycles' distant_light_uv: D towards the sun, co leaving it */
        double D[3], co[3], diff[3];
        for (int c = 0; c < 3; c++) {
            D[c] = -leaving[c];
            co[c] = -light->direction[c];               /* (the record's direction: towards the sun) */
            diff[c] = D[c] - co[c];
        }
        double factor = g->half_cot / sqrt(dot3(diff, diff));
        const double *A = g->inverse;
        uv[0] = 0.5 + ((A[0] * D[0] + A[1] * D[1]) + A[2] * D[2]) * factor;
        uv[1] = 0.5 + ((A[3] * D[0] + A[4] * D[1]) + A[5] * D[2]) * factor;
    } else if (g->uv_kind == UV_AREA) {
        double inplane[3] = {P[0] - light->position[0], P[1] - light->position[1], P[2] - light->position[2]};
        uv[0] = dot3(inplane, light->axis_u) / dot3(light->axis_u, light->axis_u) + 0.5;
        uv[1] = dot3(inplane, light->axis_v) / dot3(light->axis_v, light->axis_v) + 0.5;
    } else if (g->uv_kind == UV_SPOT) {
        double local[3];
        lamp_graph_local(g, leaving, local);
        double length = sqrt(dot3(local, local));
        double inverse = length > 0.0 ? 1.0 / length : 0.0;
        double factor = g->half_cot / -(local[2] * inverse);
        uv[0] = 0.5 + (local[0] * inverse) * factor;
        uv[1] = 0.5 + (local[1] * inverse) * factor;
    } else {                                            /* map_to_sphere(M^-1 N) */
        double co[3];
        lamp_graph_local(g, N, co);
        double length2 = dot3(co, co);
        if (length2 > 0.0) {
            uv[0] = co[0] == 0.0 && co[1] == 0.0 ? 0.0 : 0.5 - atan2(co[0], co[1]) / (2.0 * PI);
            double z = co[2] / sqrt(length2);
            uv[1] = 1.0 - acos(z < -1.0 ? -1.0 : (z > 1.0 ? 1.0 : z)) / PI;
        } else {
            uv[0] = uv[1] = 0.0;
        }
    }
}

/* LampEmission.at for one point, multiplied into color (lights.h lamp_graph_tint): the path's counts (NULL: none),
 * EMISSION alone as its flags, no footprint (lamp_graph.lamp_paths); the lamp object's Object Info and random. */
static void lamp_graph_tint(const LightRecord *light, const double *P, const double *leaving, double t,
                            const LightPath *path, double *color)
{
    const LampGraph *g = light->lamp_graph;
    if (g == NULL) return;
    ShadingPoint sp;
    double N[3], world[3], rel[3], local[3], uv[3];
    int sun = g->uv_kind == UV_SUN;
    lamp_graph_normal(light, g, P, leaving, N);
    for (int c = 0; c < 3; c++) {
        world[c] = sun ? leaving[c] : P[c] + g->origin[c];     /* (a sun's P: Cycles' Ng, the leaving direction) */
        rel[c] = world[c] - g->location[c];
    }
    lamp_graph_local(g, rel, local);
    lamp_graph_uv(light, g, P, N, leaving, uv);
    sp.width = g->width;
    for (int k = 0; k < g->width; k++) sp.attributes[k] = sp.d_du[k] = sp.d_dv[k] = 0.0;
    for (int c = 0; c < 3; c++) {
        sp.attributes[g->generated + c] = local[c];
        sp.attributes[g->object + c] = local[c];
        sp.attributes[g->uv + c] = uv[c];
        sp.N[c] = sp.Ng[c] = N[c];
        sp.I[c] = leaving[c];
        sp.P[c] = world[c];
        sp.dPdu[c] = c == 0;                        /* (graph.empty_point's) */
        sp.dPdv[c] = c == 1;
    }
    for (int c = 0; c < 9; c++) sp.L[c] = g->linear[c];
    sp.info = g->info != NULL ? g->info : NO_INFO;
    sp.info_width = g->info != NULL ? g->info_width : OBJECT_INFO_WIDTH;
    sp.rays = NULL;
    sp.random = g->random;
    sp.side = 1.0;
    LightPath none = {0, 0, 0, 0, 0, 0, 0, 0.0, 0.0};
    sp.path = path != NULL ? *path : none;
    sp.path.flags = PATH_EMISSION;
    sp.path.cone = sp.path.spread = 0.0;
    sp.u = sp.v = 0.0;
    sp.t = sun ? (double)3.4028234663852886e38f : t;   /* (a sun's: Cycles' FLT_MAX) */
    double reg[MAX_REGISTERS];
    run_program(g->graph, 0, &sp, NULL, reg);
    for (int c = 0; c < 3; c++) {
        double e = reg[g->color + c] * reg[g->strength];
        color[c] *= isfinite(e) ? e : 0.0;
    }
}
