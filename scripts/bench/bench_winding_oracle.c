/* SPDX-License-Identifier: Apache-2.0 */
/* The exact winding-number oracle for scripts/bench/bench_winding.sh (not a test).
 *
 *   bench_winding_oracle corpus DIR
 *       writes the winding corpus (tests/meshgen.c tmesh_winding_corpus) as
 *       OFF files DIR/NAME.off (and DIR/NAME.truth.off where orientation
 *       repair should change the mesh); prints "NAME FILE TRUTH" lines
 *       (TRUTH "-" when the mesh is its own truth, "none" for no oracle)
 *   bench_winding_oracle oracle MESH N OUT.npy [TRUTH.off | auto]
 *       the grid `clvox MESH -r N` uses (clvox_grid_compute, resolution N,
 *       no padding), every voxel centre classified w > 1/2 + 2^-30 by the
 *       exact generalized winding number of TRUTH (default: MESH as given;
 *       auto: each connected component of MESH oriented so that its total
 *       winding over the centres is positive), written as uint8 npy (Z, Y,
 *       X) like clvox's; prints "dims X Y Z boundary_edges B near K seconds S"
 *       (K: centres within 1e-7 of 1/2).
 *
 * The oracle is tests/reference.c's ref_winding_voxelize_rays (exact
 * crossings with the library's tie rule plus the solid angles of the
 * boundary strips, in the library's float grid space scaled back to an
 * isotropic one), which tests/test_winding.c checks against the brute-force
 * solid-angle sum. Cost: columns x triangles + voxels x boundary edges. */
#define _POSIX_C_SOURCE 200809L
#include "clvox.h"
#include "meshgen.h"
#include "reference.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>


static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void slug(const char *name, char *out, size_t n)
{
    size_t k = 0;
    for (const char *p = name; *p && k + 1 < n; p++) {
        char c = (char)tolower((unsigned char)*p);
        if (isalnum((unsigned char)c)) out[k++] = c;
        else if (k && out[k - 1] != '-') out[k++] = '-';
    }
    while (k && out[k - 1] == '-') k--;
    out[k] = 0;
}

static int write_corpus(const char *dir)
{
    tmesh_case cases[32];
    size_t n = tmesh_winding_corpus(cases, 32);
    for (size_t i = 0; i < n; i++) {
        char s[96], path[512], tpath[512];
        slug(cases[i].name, s, sizeof s);
        snprintf(path, sizeof path, "%s/%s.off", dir, s);
        if (tmesh_write_off(&cases[i].mesh, path) != 0) return fprintf(stderr, "cannot write %s\n", path), 1;
        int same = cases[i].truth.nt == cases[i].mesh.nt && cases[i].truth.nv == cases[i].mesh.nv &&
                   memcmp(cases[i].truth.tri, cases[i].mesh.tri, 3 * cases[i].mesh.nt * sizeof(uint32_t)) == 0 &&
                   memcmp(cases[i].truth.xyz, cases[i].mesh.xyz, 3 * cases[i].mesh.nv * sizeof(float)) == 0;
        if (!cases[i].truth.nt) snprintf(tpath, sizeof tpath, "none");
        else if (same) snprintf(tpath, sizeof tpath, "-");
        else {
            snprintf(tpath, sizeof tpath, "%s/%s.truth.off", dir, s);
            if (tmesh_write_off(&cases[i].truth, tpath) != 0) return fprintf(stderr, "cannot write %s\n", tpath), 1;
        }
        printf("%s %s %s\n", s, path, tpath);
        tmesh_case_free(&cases[i]);
    }
    return 0;
}

static int write_npy(const char *path, const uint8_t *v, const uint32_t dims[3])
{
    FILE *f = fopen(path, "wb");
    if (!f) return 1;
    char hdr[128];
    int len = snprintf(hdr, sizeof hdr, "{'descr': '|u1', 'fortran_order': False, 'shape': (%u, %u, %u), }", dims[2],
                       dims[1], dims[0]);
    int total = 10 + len + 1, pad = (64 - total % 64) % 64;
    unsigned char pre[10] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, 0, 0};
    pre[8] = (unsigned char)((len + 1 + pad) & 0xff), pre[9] = (unsigned char)((len + 1 + pad) >> 8);
    fwrite(pre, 1, 10, f);
    fwrite(hdr, 1, (size_t)len, f);
    for (int i = 0; i < pad; i++) fputc(' ', f);
    fputc('\n', f);
    size_t n = (size_t)dims[0] * dims[1] * dims[2];
    int ok = fwrite(v, 1, n, f) == n;
    return fclose(f) == 0 && ok ? 0 : 1;
}

static int oracle(const char *mesh_path, uint32_t res, const char *out, const char *truth)
{
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_context *ctx = NULL;
    if (clvox_context_create(&co, &ctx) != CLVOX_OK) return fprintf(stderr, "context: %s\n", clvox_context_error(ctx)), 1;
    clvox_mesh *m = NULL, *tm = NULL;
    if (clvox_mesh_load(ctx, mesh_path, &m) != CLVOX_OK)
        return fprintf(stderr, "%s: %s\n", mesh_path, clvox_context_error(ctx)), 1;
    const clvox_mesh_report *r = clvox_mesh_get_report(m);
    clvox_grid_options go = CLVOX_GRID_OPTIONS_INIT;
    go.resolution = res;
    clvox_grid g;
    if (clvox_grid_compute(ctx, &go, r->bbox_min, r->bbox_max, &g) != CLVOX_OK)
        return fprintf(stderr, "grid: %s\n", clvox_context_error(ctx)), 1;
    int autoorient = truth && strcmp(truth, "auto") == 0;
    const clvox_mesh *src = m;
    if (truth && !autoorient) {
        if (clvox_mesh_load(ctx, truth, &tm) != CLVOX_OK)
            return fprintf(stderr, "%s: %s\n", truth, clvox_context_error(ctx)), 1;
        src = tm;
    }
    /* the library's vertices are relative to the mesh's offset: move the origin likewise */
    double off[3];
    clvox_mesh_vertex_offset(src, off);
    clvox_grid gref = g;
    for (int a = 0; a < 3; a++) gref.origin[a] = g.origin[a] - off[a];
    size_t nv, nt, n = (size_t)g.dims[0] * g.dims[1] * g.dims[2];
    const float *xyz = clvox_mesh_vertices(src, &nv);
    const uint32_t *tri = clvox_mesh_triangles(src, &nt);
    uint8_t *v = malloc(n);
    double *w = calloc(n, sizeof *w), *wc = malloc(n * sizeof *wc);
    uint32_t *label = malloc((nt ? nt : 1) * sizeof *label), *sub = malloc((nt ? nt : 1) * 3 * sizeof *sub);
    if (!v || !w || !wc || !label || !sub) return fprintf(stderr, "out of memory\n"), 1;
    double t0 = now();
    size_t ncomp = autoorient ? tmesh_components_of(xyz, nv, tri, nt, label) : 1, edges = 0, flipped = 0;
    for (size_t c = 0; c < ncomp; c++) {
        size_t ns = 0;
        for (size_t t = 0; t < nt; t++)
            if (!autoorient || label[t] == c) memcpy(sub + 3 * ns++, tri + 3 * t, 3 * sizeof *sub);
        edges += ref_winding_voxelize_rays(xyz, nv, sub, ns, &gref, 0, v, wc);
        double total = 0;
        for (size_t k = 0; k < n; k++) total += wc[k];
        double sign = autoorient && total < 0 ? -1.0 : 1.0;
        flipped += sign < 0;
        for (size_t k = 0; k < n; k++) w[k] += sign * wc[k];
    }
    size_t near = 0, inside = 0;
    for (size_t k = 0; k < n; k++) {
        v[k] = (uint8_t)ref_winding_inside(w[k], 0);
        inside += v[k];
        near += fabs(w[k] - 0.5) < 1e-7;
    }
    double secs = now() - t0;
    int rc = write_npy(out, v, g.dims);
    printf("dims %u %u %u boundary_edges %zu near %zu inside %zu components %zu inverted %zu seconds %.2f\n",
           g.dims[0], g.dims[1], g.dims[2], edges, near, inside, ncomp, flipped, secs);
    free(v);
    free(w);
    free(wc);
    free(label);
    free(sub);
    clvox_mesh_destroy(m);
    clvox_mesh_destroy(tm);
    clvox_context_destroy(ctx);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "corpus") == 0) return write_corpus(argv[2]);
    if ((argc == 5 || argc == 6) && strcmp(argv[1], "oracle") == 0)
        return oracle(argv[2], (uint32_t)strtoul(argv[3], NULL, 10), argv[4], argc == 6 ? argv[5] : NULL);
    fprintf(stderr, "usage: bench_winding_oracle corpus DIR | oracle MESH N OUT.npy [TRUTH.off|auto]\n");
    return 2;
}
