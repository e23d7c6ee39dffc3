/* A world made of shader nodes: core/lights/world_graph.py. Its program (graph.c run_program) run along a direction,
 * for the texels of its bake (world_bake_rows) and for each camera ray that escapes (world_seen). */

/* world_graph.world_point: the world's shading point along the unit D, as Cycles' shader_setup_from_background
 * sets it up (P and the Generated and Object coordinates D, N, Ng and I -D, the ray's length FLT_MAX), with the
 * path `path` (graph.empty_point's other fields: no object, an identity transform). */
INLINE void world_point_at(const WorldGraph *g, const double *D, const LightPath *path, ShadingPoint *sp)
{
    sp->width = g->width;
    for (int k = 0; k < g->width; k++) sp->attributes[k] = sp->d_du[k] = sp->d_dv[k] = 0.0;
    for (int c = 0; c < 3; c++) {
        sp->attributes[g->generated + c] = D[c];
        sp->attributes[g->object + c] = D[c];
        sp->N[c] = sp->Ng[c] = sp->I[c] = -D[c];
        sp->P[c] = D[c];
        sp->dPdu[c] = c == 0;
        sp->dPdv[c] = c == 1;
    }
    for (int c = 0; c < 9; c++) sp->L[c] = c % 4 == 0;
    sp->info = NO_INFO;                                 /* (no object: its Object Info reads 0) */
    sp->info_width = OBJECT_INFO_WIDTH;
    sp->rays = NULL;                                    /* (world shaders trace nothing) */
    sp->aov = NULL;                                     /* (no shader AOVs written: world_graph_aovs sets them) */
    sp->random = 0.0;
    sp->side = 1.0;
    sp->path = *path;
    sp->u = sp->v = 0.0;
    sp->t = (double)3.4028234663852886e38f;         /* FLT_MAX */
}

/* world_graph.radiance_along at one direction: the program's colour x strength along D for `path` (reg: room for
 * MAX_REGISTERS). */
INLINE void world_graph_radiance(const WorldGraph *g, const double *D, const LightPath *path, double *reg, double *out)
{
    ShadingPoint sp;
    world_point_at(g, D, path, &sp);
    run_program(g->graph, 0, &sp, NULL, reg);
    for (int c = 0; c < 3; c++) out[c] = reg[g->color + c] * reg[g->strength];
}

/* world_graph.aovs_along at one direction: what the world's AOV Output nodes (a compile_aovs program) write for a
 * camera chain's ray along the unit D that escapes, with its path (EMISSION added, as Cycles evaluates a background),
 * added into the lane's shader AOVs `into` (a COLOR AOV its Color and 1 into its alpha, a VALUE AOV its Value). */
INLINE void world_graph_aovs(const WorldGraph *g, const double *D, const LightPath *path, double *into)
{
    double reg[MAX_REGISTERS];
    ShadingPoint sp;
    LightPath emission = *path;
    emission.flags |= PATH_EMISSION;
    world_point_at(g, D, &emission, &sp);
    sp.aov = into;                                      /* (the ops after AOV_START run) */
    run_program(g->graph, 0, &sp, NULL, reg);
    const double *info = g->graph->programs;            /* (its one program) */
    add_aovs(g->graph->outputs + 5 * (int64_t)info[5], (int64_t)info[6], reg, into);
}

/* World.radiance_seen: what a ray along the unit D that escapes finds, with its path (NULL: none known, the bake): the
 * world's program evaluated for it, EMISSION added (WorldProgram.along: negative and non-finite channels 0), where the
 * world has one, else world_radiance. */
INLINE void world_seen(const WorldTables *w, const double *D, const LightPath *path, double *out)
{
    if (w->seen == NULL || path == NULL) {
        world_radiance(w, D, out);
        return;
    }
    double reg[MAX_REGISTERS];
    LightPath emission = *path;
    emission.flags |= PATH_EMISSION;
    world_graph_radiance(w->seen, D, &emission, reg, out);
    for (int c = 0; c < 3; c++) out[c] = isfinite(out[c]) && out[c] > 0.0 ? out[c] : 0.0;
}

/* world_seen, and WorldLight.pdf of D into `pdf` where it is not NULL (a ray weighed by MIS): where no graph runs per
 * ray, one conversion of D to the image's coordinates serves both. */
INLINE void world_seen_pdf(const WorldTables *w, const double *D, const LightPath *path, double *out, double *pdf)
{
    if (pdf != NULL && (w->seen == NULL || path == NULL)) {
        *pdf = world_radiance_pdf(w, D, out);
        return;
    }
    world_seen(w, D, path, out);
    if (pdf != NULL)
        *pdf = world_pdf(w, D);
}

/* world_graph.compiled_bake's band: rows row_start .. row_end - 1 of the bake, texel (i, j) the program along the
 * direction of u = (j + 1/2) / W, v = (i + 1/2) / H (world.c world_direction), for a path of `flags` alone. */
static void world_bake_rows(const WorldBakeArgs *a)
{
    double reg[MAX_REGISTERS], D[3], L[3];
    LightPath path = {a->flags, 0, 0, 0, 0, 0, 0, 0.0, 0.0};
    for (int64_t i = a->row_start; i < a->row_end; i++)
        for (int64_t j = 0; j < a->width; j++) {
            double u = ((double)j + 0.5) / (double)a->width, v = ((double)i + 0.5) / (double)a->height, sin_theta;
            world_direction(u, v, D, &sin_theta);
            world_graph_radiance(a->world, D, &path, reg, L);
            for (int c = 0; c < 3; c++) a->radiance[3 * (i * a->width + j) + c] = (float)L[c];
        }
}
