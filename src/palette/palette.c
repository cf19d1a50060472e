/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Palettes of sub-voxel elements (Cavagnino & Gribaudo, sections 2-2.1):
 * the built-ins, the user palette file, symmetry expansion with duplicate
 * removal, and per-element information. Geometry, boundary rule and array
 * layout: kernels/palette.h. File format: docs/design.md "Palette files".
 *
 * Symmetries. The 48 symmetries of the cube act on the unit voxel as
 * p -> S (p - h) + h, h = (1/2, 1/2, 1/2), S a signed permutation matrix:
 * (S p)_i = sign_i * p_perm(i). Symmetry index s = 8 * P + m, P the index
 * of perm in the lexicographic list below (0 = identity), bit i of m set when
 * sign_i = -1; s = 0 is the identity. A half-space a.p <= d maps onto
 * (S a).q <= d - a.h + (S a).h, so coefficients 0, +-1, +-2 and d in halves
 * stay so: the images of the built-ins are exact in float.
 *
 * Duplicates. Two elements are the same when their membership agrees on the
 * 16^3 offset grid p = ((i, j, k) + 1/2 + (1, 3, 9)/64) / 16 (the element's
 * mask). For planes with a, b, c in {0, +-1, +-2} (not all 0) and d a
 * multiple of 1/2 no grid point lies on a plane: a.p = d would need
 * a.(1, 3, 9)/64 to be a multiple of 1/2, but it is non-zero (1, 3, 9 with
 * digits -2..2 is a balanced base-3 code) and at most 26/64 in magnitude. The
 * points are dyadic with 10 fraction bits, so the float test of
 * kernels/palette.h is exact at them, and open and closed boundaries (a
 * complement versus a mirror image) do not matter: the masks compare the
 * elements as sets up to their boundaries, which is the equality the scoring
 * can see. Equal masks are taken as equal elements; for the built-ins this
 * is sound because they are single convex cells (or complements of one)
 * whose planes all cut the voxel, so two of them differ by a polytope of
 * volume >= 1/48 with an inradius far above the grid step, and tests/
 * test_palette.c checks the counts 12, 12, 12, 8 against the paper's 46 and
 * 78 and every pair again on a 32^3 grid. For user palettes with other
 * coefficients the test is a 16^3 sampling: elements differing only in
 * slivers thinner than 1/16 voxel may be merged (documented).
 *
 * Order (documented in docs/design.md): 0 empty, 1 full; planar10 the four
 * half-boxes x<=1/2, x>=1/2, y<=1/2, y>=1/2, then the four diagonal prisms
 * with corners (0,0), (1,0), (0,1), (1,1); paper46 the images of wedge,
 * roof, column, corner in that order, each group in increasing order of the
 * first symmetry index that produces the image (so the basic element comes
 * first); paper78 appends the complements of elements 2..45 in index order,
 * skipping those already present; a file keeps its order, each element
 * followed by its new images.
 */
#include "core/internal.h"
#include "palette/line_parser.h"
#include "../../kernels/palette.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_ELEMENT_CELLS 64u
#define MAX_ELEMENT_PLANES 64u
#define MAX_ELEMENTS 1024u
#define MAX_NAME 47u                        /* room for a "_s47" suffix in 64 bytes */
#define MAX_FILE_BYTES (4u << 20)
#define MAX_COEFF 1e6
#define MASK_N 16u
#define MASK_BYTES (MASK_N * MASK_N * MASK_N / 8u)
#define VOLUME_N 64u
#define WORK_BUDGET (1ull << 26)            /* plane tests spent on masks of one palette */

typedef struct meta {
    char name[64];
    double volume;
    int volume_exact;
    uint32_t basic, symmetry, complement_of;
    uint8_t mask[MASK_BYTES];
} meta;

struct clvox_palette {
    char name[64];
    clvox_element *elements;
    meta *meta;
    size_t count, cap;
    clvox_cell *cells;
    size_t ncells, cells_cap;
    clvox_halfspace *planes;
    size_t nplanes, planes_cap;
    uint64_t work;
    char *source;        /* the text parsed (user palettes), NUL-terminated; NULL for built-ins */
};

/* One element under construction: cells of planes, in order. */
typedef struct shape {
    clvox_halfspace plane[MAX_ELEMENT_PLANES];
    uint32_t cell_planes[MAX_ELEMENT_CELLS];
    uint32_t ncells, nplanes;
    int complement;
} shape;

/* ---- symmetries ---- */

static const int8_t perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

static void sym_matrix(uint32_t s, int32_t m[3][3])
{
    memset(m, 0, 9 * sizeof m[0][0]);
    for (int i = 0; i < 3; i++) m[i][perms[s / 8][i]] = (s >> i) & 1u ? -1 : 1;
}

static clvox_halfspace sym_plane(uint32_t s, clvox_halfspace h)
{
    float a[3] = {h.a, h.b, h.c}, sa[3];
    for (int i = 0; i < 3; i++) sa[i] = ((s >> i) & 1u ? -1.0f : 1.0f) * a[perms[s / 8][i]];
    double d = (double)h.d - 0.5 * ((double)a[0] + a[1] + a[2]) + 0.5 * ((double)sa[0] + sa[1] + sa[2]);
    clvox_halfspace r = {sa[0], sa[1], sa[2], (float)d};
    return r;
}

static void sym_shape(uint32_t s, const shape *in, shape *out)
{
    *out = *in;
    for (uint32_t k = 0; k < in->nplanes; k++) out->plane[k] = sym_plane(s, in->plane[k]);
}

/* ---- shapes ---- */

/* Flat arrays of one shape, as element 0 for clvox_element_contains. */
typedef struct flat {
    clvox_element e;
    clvox_cell c[MAX_ELEMENT_CELLS];
} flat;

static void shape_flat(const shape *s, flat *f)
{
    f->e.first_cell = 0;
    f->e.cell_count = s->ncells;
    f->e.complement = s->complement ? 1u : 0u;
    f->e.pad = 0;
    uint32_t first = 0;
    for (uint32_t c = 0; c < s->ncells; c++) {
        f->c[c].first_plane = first;
        f->c[c].plane_count = s->cell_planes[c];
        first += s->cell_planes[c];
    }
}

/* Offset grid point i of n along axis `axis`: (i + 1/2 + (1, 3, 9)[axis]/64) / n. */
static float grid_point(uint32_t i, uint32_t n, int axis)
{
    static const int off[3] = {33, 35, 41};
    return (float)((double)(i * 64u + (uint32_t)off[axis]) / (64.0 * n));
}

static void shape_mask(const shape *s, uint8_t *mask)
{
    flat f;
    shape_flat(s, &f);
    memset(mask, 0, MASK_BYTES);
    for (uint32_t k = 0, bit = 0; k < MASK_N; k++)
        for (uint32_t j = 0; j < MASK_N; j++)
            for (uint32_t i = 0; i < MASK_N; i++, bit++)
                if (clvox_element_contains(&f.e, f.c, s->plane, 0, grid_point(i, MASK_N, 0), grid_point(j, MASK_N, 1),
                                           grid_point(k, MASK_N, 2)))
                    mask[bit / 8] |= (uint8_t)(1u << (bit % 8));
}

static void add_plane(shape *s, float a, float b, float c, float d)
{
    clvox_halfspace h = {a, b, c, d};
    s->plane[s->nplanes++] = h;
    s->cell_planes[s->ncells - 1]++;
}

static void add_cell(shape *s) { s->cell_planes[s->ncells++] = 0; }

/* ---- palette building ---- */

static clvox_status grow(clvox_context *ctx, void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return CLVOX_OK;
    size_t n = *cap ? *cap : 16;
    while (n < need) n *= 2;
    void *q = realloc(*p, n * elem);
    if (!q) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "palette: out of memory");
    *p = q;
    *cap = n;
    return CLVOX_OK;
}

static clvox_palette *palette_new(const char *name)
{
    clvox_palette *p = calloc(1, sizeof *p);
    if (p) snprintf(p->name, sizeof p->name, "%s", name);
    return p;
}

static uint32_t find_mask(const clvox_palette *p, const uint8_t *mask)
{
    for (size_t i = 0; i < p->count; i++)
        if (memcmp(p->meta[i].mask, mask, MASK_BYTES) == 0) return (uint32_t)i;
    return CLVOX_PALETTE_NONE;
}

/* Adds shape s unless an equal element exists. *index gets the new or the
 * existing element; *added whether it is new. The new element's meta is m
 * (name, volume, basic, symmetry, complement_of). */
static clvox_status push(clvox_context *ctx, clvox_palette *p, const shape *s, const meta *m, uint32_t *index,
                         int *added)
{
    p->work += (uint64_t)(s->nplanes + 1) * MASK_N * MASK_N * MASK_N;
    if (p->work > WORK_BUDGET)
        return clvox__fail(ctx, CLVOX_ERR_PALETTE_FORMAT, "palette too complex (over %llu plane tests for duplicates)",
                           (unsigned long long)WORK_BUDGET);
    meta tmp = *m;
    shape_mask(s, tmp.mask);
    uint32_t found = find_mask(p, tmp.mask);
    *added = found == CLVOX_PALETTE_NONE;
    if (!*added) {
        *index = found;
        return CLVOX_OK;
    }
    if (p->count >= MAX_ELEMENTS)
        return clvox__fail(ctx, CLVOX_ERR_PALETTE_FORMAT, "more than %u elements", MAX_ELEMENTS);
    clvox_status st;
    if ((st = grow(ctx, (void **)&p->elements, &p->cap, p->count + 1, sizeof *p->elements)) != CLVOX_OK) return st;
    size_t mcap = p->cap;
    meta *nm = realloc(p->meta, mcap * sizeof *nm);
    if (!nm) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "palette: out of memory");
    p->meta = nm;
    if ((st = grow(ctx, (void **)&p->cells, &p->cells_cap, p->ncells + s->ncells, sizeof *p->cells)) != CLVOX_OK)
        return st;
    if ((st = grow(ctx, (void **)&p->planes, &p->planes_cap, p->nplanes + s->nplanes, sizeof *p->planes)) != CLVOX_OK)
        return st;
    clvox_element *e = &p->elements[p->count];
    e->first_cell = (uint32_t)p->ncells;
    e->cell_count = s->ncells;
    e->complement = s->complement ? 1u : 0u;
    e->pad = 0;
    uint32_t first = (uint32_t)p->nplanes;
    for (uint32_t c = 0; c < s->ncells; c++) {
        p->cells[p->ncells].first_plane = first;
        p->cells[p->ncells].plane_count = s->cell_planes[c];
        p->ncells++;
        first += s->cell_planes[c];
    }
    if (s->nplanes) memcpy(p->planes + p->nplanes, s->plane, s->nplanes * sizeof *s->plane);
    p->nplanes += s->nplanes;
    if (tmp.basic == CLVOX_PALETTE_NONE) tmp.basic = (uint32_t)p->count;
    p->meta[p->count] = tmp;
    *index = (uint32_t)p->count++;
    return CLVOX_OK;
}

static meta make_meta(const char *name, double volume, int exact)
{
    meta m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "%s", name);
    m.volume = volume;
    m.volume_exact = exact;
    m.basic = CLVOX_PALETTE_NONE;
    m.complement_of = CLVOX_PALETTE_NONE;
    return m;
}

/* Empty (no cell) and full (one cell, no plane): indices 0 and 1. */
static clvox_status push_trivial(clvox_context *ctx, clvox_palette *p)
{
    shape s;
    memset(&s, 0, sizeof s);
    uint32_t idx;
    int added;
    meta m = make_meta("empty", 0.0, 1);
    clvox_status st = push(ctx, p, &s, &m, &idx, &added);
    if (st != CLVOX_OK) return st;
    add_cell(&s);
    m = make_meta("full", 1.0, 1);
    return push(ctx, p, &s, &m, &idx, &added);
}

/* Pushes the images of basic shape s under the symmetries s for which
 * keep(sym) holds (all when keep is NULL), in increasing symmetry order.
 * Image names: the basic name, then "<name>_s<k>"; names[name_count] (may
 * be NULL) overrides them for the new images, in order (a repeated image is
 * not added, so it needs no name). The basic element is the first image's index.
 * *new_count gets how many were new. */
static clvox_status push_images(clvox_context *ctx, clvox_palette *p, const shape *s, const char *name,
                                double volume, int exact, int (*keep)(uint32_t), const char *const *names,
                                uint32_t name_count, uint32_t *new_count)
{
    uint32_t basic = CLVOX_PALETTE_NONE, n = 0;
    for (uint32_t sym = 0; sym < 48; sym++) {
        if (keep && !keep(sym)) continue;
        shape img;
        sym_shape(sym, s, &img);
        char nm[64];
        if (names && n < name_count) snprintf(nm, sizeof nm, "%s", names[n]);
        else if (sym == 0) snprintf(nm, sizeof nm, "%s", name);
        else snprintf(nm, sizeof nm, "%s_s%u", name, (unsigned)sym);
        meta m = make_meta(nm, volume, exact);
        m.basic = basic;
        m.symmetry = basic == CLVOX_PALETTE_NONE ? 0 : sym;
        uint32_t idx;
        int added;
        clvox_status st = push(ctx, p, &img, &m, &idx, &added);
        if (st != CLVOX_OK) return st;
        if (basic == CLVOX_PALETTE_NONE) basic = idx;
        if (added) n++;
    }
    if (new_count) *new_count = n;
    return CLVOX_OK;
}

/* Symmetries that keep z (planar10: constant along z, mirrors in xy). */
static int keeps_z(uint32_t sym) { return perms[sym / 8][2] == 2 && !((sym >> 2) & 1u); }

/* Complements of elements [2, end) not already present (paper78). */
static clvox_status push_complements(clvox_context *ctx, clvox_palette *p, size_t end)
{
    uint32_t comp[MAX_ELEMENTS];
    for (size_t i = 0; i < end; i++) comp[i] = CLVOX_PALETTE_NONE;
    for (size_t i = 2; i < end; i++) {
        const clvox_element *e = &p->elements[i];
        shape s;
        memset(&s, 0, sizeof s);
        for (uint32_t c = 0; c < e->cell_count; c++) {
            const clvox_cell *cell = &p->cells[e->first_cell + c];
            add_cell(&s);
            for (uint32_t k = 0; k < cell->plane_count; k++) {
                clvox_halfspace h = p->planes[cell->first_plane + k];
                add_plane(&s, h.a, h.b, h.c, h.d);
            }
        }
        s.complement = !e->complement;
        const meta *src = &p->meta[i];
        char nm[64];
        snprintf(nm, sizeof nm, "not_%.50s", src->name);
        meta m = make_meta(nm, 1.0 - src->volume, src->volume_exact);
        m.complement_of = (uint32_t)i;
        m.basic = src->basic < end && comp[src->basic] != CLVOX_PALETTE_NONE ? comp[src->basic] : CLVOX_PALETTE_NONE;
        m.symmetry = m.basic == CLVOX_PALETTE_NONE ? 0 : src->symmetry;
        uint32_t idx;
        int added;
        clvox_status st = push(ctx, p, &s, &m, &idx, &added);
        if (st != CLVOX_OK) return st;
        if (added) comp[i] = idx;
    }
    return CLVOX_OK;
}

static clvox_status build_paper46(clvox_context *ctx, clvox_palette *p)
{
    clvox_status st = push_trivial(ctx, p);
    shape s;
    /* diagonal wedge x + y <= 1 */
    memset(&s, 0, sizeof s);
    add_cell(&s);
    add_plane(&s, 1, 1, 0, 1);
    if (st == CLVOX_OK) st = push_images(ctx, p, &s, "wedge", 0.5, 1, NULL, NULL, 0, NULL);
    /* roof prism z <= 2x and z <= 2 - 2x */
    memset(&s, 0, sizeof s);
    add_cell(&s);
    add_plane(&s, -2, 0, 1, 0);
    add_plane(&s, 2, 0, 1, 2);
    if (st == CLVOX_OK) st = push_images(ctx, p, &s, "roof", 0.5, 1, NULL, NULL, 0, NULL);
    /* quarter column x <= 1/2 and y <= 1/2 */
    memset(&s, 0, sizeof s);
    add_cell(&s);
    add_plane(&s, 1, 0, 0, 0.5f);
    add_plane(&s, 0, 1, 0, 0.5f);
    if (st == CLVOX_OK) st = push_images(ctx, p, &s, "column", 0.25, 1, NULL, NULL, 0, NULL);
    /* corner tetrahedron x + y + z <= 1 */
    memset(&s, 0, sizeof s);
    add_cell(&s);
    add_plane(&s, 1, 1, 1, 1);
    if (st == CLVOX_OK) st = push_images(ctx, p, &s, "corner", 1.0 / 6.0, 1, NULL, NULL, 0, NULL);
    return st;
}

static clvox_status build_builtin(clvox_context *ctx, clvox_palette *p, int which)
{
    clvox_status st;
    switch (which) {
    case 0: return push_trivial(ctx, p);
    case 1: {
        static const char *const halves[] = {"half_x_lo", "half_x_hi", "half_y_lo", "half_y_hi"};
        static const char *const diags[] = {"diag_00", "diag_10", "diag_01", "diag_11"};
        st = push_trivial(ctx, p);
        shape s;
        memset(&s, 0, sizeof s);
        add_cell(&s);
        add_plane(&s, 1, 0, 0, 0.5f);
        if (st == CLVOX_OK) st = push_images(ctx, p, &s, "half", 0.5, 1, keeps_z, halves, 4, NULL);
        memset(&s, 0, sizeof s);
        add_cell(&s);
        add_plane(&s, 1, 1, 0, 1);
        if (st == CLVOX_OK) st = push_images(ctx, p, &s, "diag", 0.5, 1, keeps_z, diags, 4, NULL);
        return st;
    }
    case 2: return build_paper46(ctx, p);
    default:
        st = build_paper46(ctx, p);
        if (st == CLVOX_OK) st = push_complements(ctx, p, p->count);
        return st;
    }
}

static const char *const builtin_names[] = {"binary", "planar10", "paper46", "paper78"};
static const size_t builtin_counts[] = {2, 10, 46, 78};

const char *clvox_palette_builtin_name(size_t i)
{
    return i < sizeof builtin_names / sizeof builtin_names[0] ? builtin_names[i] : NULL;
}

void clvox_palette_destroy(clvox_palette *palette)
{
    if (!palette) return;
    free(palette->elements);
    free(palette->meta);
    free(palette->cells);
    free(palette->planes);
    free(palette->source);
    free(palette);
}

clvox_status clvox_palette_builtin(clvox_context *ctx, const char *name, clvox_palette **out)
{
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_palette_builtin: out is NULL");
    *out = NULL;
    if (!name) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_palette_builtin: name is NULL");
    for (int i = 0; i < 4; i++) {
        if (strcmp(name, builtin_names[i]) != 0) continue;
        clvox_palette *p = palette_new(name);
        if (!p) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "palette: out of memory");
        clvox_status st = build_builtin(ctx, p, i);
        if (st == CLVOX_OK && p->count != builtin_counts[i])
            st = clvox__fail(ctx, CLVOX_ERR_INTERNAL, "palette %s has %zu elements, expected %zu", name, p->count,
                             builtin_counts[i]);
        if (st != CLVOX_OK) {
            clvox_palette_destroy(p);
            return st;
        }
        *out = p;
        return CLVOX_OK;
    }
    return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT,
                       "unknown palette '%.200s' (built-in: binary, planar10, paper46, paper78; or a palette file)",
                       name);
}

/* ---- palette files ---- */

typedef struct parser {
    clvox__line_parser lp; /* context, source and line, for messages */
    clvox_palette *p;
    int open;            /* inside element ... end */
    unsigned open_line;
    char name[64];
    int symmetry;
    shape s;
} parser;

#define PFAIL(ps, ...) clvox__line_fail(&(ps)->lp, __VA_ARGS__)

static int name_taken(const clvox_palette *p, const char *name)
{
    for (size_t i = 0; i < p->count; i++)
        if (strcmp(p->meta[i].name, name) == 0) return 1;
    return 0;
}

/* `end`: adds the element and, with `symmetry`, its images. */
static clvox_status finish_element(parser *ps)
{
    clvox_palette *p = ps->p;
    if (!ps->symmetry) {
        meta m = make_meta(ps->name, 0.0, 0);
        uint32_t idx;
        int added;
        clvox_status st = push(ps->lp.ctx, p, &ps->s, &m, &idx, &added);
        if (st == CLVOX_ERR_PALETTE_FORMAT) return PFAIL(ps, "%s", clvox_context_error(ps->lp.ctx));
        return st;
    }
    size_t before = p->count;
    clvox_status st = push_images(ps->lp.ctx, p, &ps->s, ps->name, 0.0, 0, NULL, NULL, 0, NULL);
    if (st == CLVOX_ERR_PALETTE_FORMAT) return PFAIL(ps, "%s", clvox_context_error(ps->lp.ctx));
    if (st != CLVOX_OK) return st;
    /* generated names must not clash with earlier ones */
    for (size_t i = before; i < p->count; i++)
        for (size_t j = 0; j < i; j++)
            if (strcmp(p->meta[i].name, p->meta[j].name) == 0)
                return PFAIL(ps, "symmetry image name '%s' is already taken", p->meta[i].name);
    return CLVOX_OK;
}

static int parse_number(const char *tok, float *out)
{
    char *end = NULL;
    errno = 0;
    double v = strtod(tok, &end);
    if (end == tok || *end != '\0' || errno == ERANGE || !isfinite(v) || fabs(v) > MAX_COEFF) return 0;
    *out = (float)v;
    return 1;
}

/* One line's fields (clvox__parse_lines: comments removed, at most 6). */
static clvox_status parse_line(void *user, char **tok, int n)
{
    parser *ps = user;
    const char *kw = tok[0];
    char c0 = kw[0];
    int numeric = (c0 >= '0' && c0 <= '9') || c0 == '-' || c0 == '+' || c0 == '.';
    if (numeric) {
        if (!ps->open) return PFAIL(ps, "half-space outside an element");
        if (ps->s.ncells == 0) return PFAIL(ps, "half-space before the element's first 'cell'");
        if (n != 4) return PFAIL(ps, "a half-space is 4 numbers 'a b c d' (a*x + b*y + c*z <= d), got %d fields", n);
        float v[4];
        for (int i = 0; i < 4; i++)
            if (!parse_number(tok[i], &v[i]))
                return PFAIL(ps, "'%.64s' is not a finite number of magnitude <= 1e6", tok[i]);
        if (v[0] == 0 && v[1] == 0 && v[2] == 0) return PFAIL(ps, "half-space with a = b = c = 0");
        if (ps->s.nplanes >= MAX_ELEMENT_PLANES)
            return PFAIL(ps, "more than %u half-spaces in element '%s'", MAX_ELEMENT_PLANES, ps->name);
        add_plane(&ps->s, v[0], v[1], v[2], v[3]);
        return CLVOX_OK;
    }
    if (strcmp(kw, "element") == 0) {
        if (ps->open) return PFAIL(ps, "'element' inside element '%s' (line %u has no 'end')", ps->name, ps->open_line);
        if (n != 2) return PFAIL(ps, "'element' takes one name");
        if (!clvox__line_valid_name(tok[1], MAX_NAME))
            return PFAIL(ps, "bad element name '%.64s' (1-%u characters of A-Z a-z 0-9 _ - .)", tok[1], MAX_NAME);
        if (name_taken(ps->p, tok[1])) return PFAIL(ps, "element name '%s' is already taken", tok[1]);
        ps->open = 1;
        ps->open_line = ps->lp.line;
        snprintf(ps->name, sizeof ps->name, "%s", tok[1]);
        ps->symmetry = 0;
        memset(&ps->s, 0, sizeof ps->s);
        return CLVOX_OK;
    }
    int known = strcmp(kw, "cell") == 0 || strcmp(kw, "complement") == 0 || strcmp(kw, "symmetry") == 0 ||
                strcmp(kw, "end") == 0;
    if (!known) return PFAIL(ps, "unknown directive '%.64s'", kw);
    if (!ps->open) return PFAIL(ps, "'%s' outside an element", kw);
    if (n != 1) return PFAIL(ps, "'%s' takes no arguments", kw);
    if (strcmp(kw, "cell") == 0) {
        if (ps->s.ncells >= MAX_ELEMENT_CELLS)
            return PFAIL(ps, "more than %u cells in element '%s'", MAX_ELEMENT_CELLS, ps->name);
        add_cell(&ps->s);
    } else if (strcmp(kw, "complement") == 0) {
        if (ps->s.complement) return PFAIL(ps, "'complement' given twice");
        ps->s.complement = 1;
    } else if (strcmp(kw, "symmetry") == 0) {
        if (ps->symmetry) return PFAIL(ps, "'symmetry' given twice");
        ps->symmetry = 1;
    } else {
        ps->open = 0;
        return finish_element(ps);
    }
    return CLVOX_OK;
}

clvox_status clvox_palette_parse(clvox_context *ctx, const char *source, const char *text, size_t size,
                                 clvox_palette **out)
{
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_palette_parse: out is NULL");
    *out = NULL;
    if (!text && size) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_palette_parse: text is NULL");
    if (!source) source = "palette";
    /* palette name: the source's base name without its extension */
    const char *base = strrchr(source, '/');
    base = base ? base + 1 : source;
    char pname[64];
    snprintf(pname, sizeof pname, "%.63s", base);
    char *dot = strrchr(pname, '.');
    if (dot && dot != pname) *dot = '\0';

    parser *ps = calloc(1, sizeof *ps);
    clvox_palette *p = palette_new(pname);
    clvox_status st = CLVOX_OK;
    if (!ps || !p) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "palette: out of memory");
    if (st == CLVOX_OK) {
        ps->lp.ctx = ctx;
        ps->lp.source = source;
        ps->p = p;
        st = push_trivial(ctx, p);
    }
    if (st == CLVOX_OK) st = clvox__parse_lines(&ps->lp, "palette", text, size, 6, parse_line, ps);
    if (st == CLVOX_OK && ps->open) {
        ps->lp.line = ps->open_line;
        st = PFAIL(ps, "element '%s' has no 'end'", ps->name);
    }
    free(ps);
    if (st == CLVOX_OK) { /* kept verbatim: volumes record it in their header */
        p->source = malloc(size + 1);
        if (!p->source) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "palette: out of memory");
        else {
            if (size) memcpy(p->source, text, size);
            p->source[size] = '\0';
        }
    }
    if (st != CLVOX_OK) {
        clvox_palette_destroy(p);
        return st;
    }
    *out = p;
    return CLVOX_OK;
}

clvox_status clvox_palette_load(clvox_context *ctx, const char *path, clvox_palette **out)
{
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_palette_load: out is NULL");
    *out = NULL;
    if (!path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_palette_load: path is NULL");
    char *data = NULL;
    size_t n = 0;
    clvox_status st = clvox__read_text_file(ctx, path, "palette", MAX_FILE_BYTES, &data, &n);
    if (st == CLVOX_OK) st = clvox_palette_parse(ctx, path, data, n, out);
    free(data);
    return st;
}

/* ---- queries ---- */

const char *clvox_palette_name(const clvox_palette *palette) { return palette ? palette->name : ""; }

size_t clvox_palette_count(const clvox_palette *palette) { return palette ? palette->count : 0; }

int clvox_palette_contains(const clvox_palette *palette, size_t index, float x, float y, float z)
{
    if (!palette || index >= palette->count) return 0;
    return clvox_element_contains(palette->elements, palette->cells, palette->planes, (clvox_u32)index, x, y, z);
}

static clvox_status element_info_get(clvox_context *ctx, const clvox_palette *palette, size_t index,
                                     clvox_palette_element_info *info)
{
    if (index >= palette->count)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "palette '%s' has %zu elements, no index %zu",
                           palette->name, palette->count, index);
    const meta *m = &palette->meta[index];
    const clvox_element *e = &palette->elements[index];
    memset(info, 0, sizeof *info);
    snprintf(info->name, sizeof info->name, "%s", m->name);
    info->volume_exact = m->volume_exact;
    info->volume = m->volume;
    if (!m->volume_exact) {
        uint64_t in = 0;
        for (uint32_t k = 0; k < VOLUME_N; k++)
            for (uint32_t j = 0; j < VOLUME_N; j++)
                for (uint32_t i = 0; i < VOLUME_N; i++)
                    in += (uint64_t)clvox_element_contains(palette->elements, palette->cells, palette->planes,
                                                           (clvox_u32)index, grid_point(i, VOLUME_N, 0),
                                                           grid_point(j, VOLUME_N, 1), grid_point(k, VOLUME_N, 2));
        info->volume = (double)in / ((double)VOLUME_N * VOLUME_N * VOLUME_N);
    }
    info->basic = m->basic;
    info->symmetry = m->symmetry;
    sym_matrix(m->symmetry, info->matrix);
    info->complement_of = m->complement_of;
    info->cell_count = e->cell_count;
    for (uint32_t c = 0; c < e->cell_count; c++) info->plane_count += palette->cells[e->first_cell + c].plane_count;
    info->complement = (int)e->complement;
    return CLVOX_OK;
}

clvox_status clvox_palette_element_info_get(clvox_context *ctx, const clvox_palette *palette, size_t index,
                                            clvox_palette_element_info *info)
{
    if (!palette || !info) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_palette_element_info_get: NULL");
    /* filled whole here, then as much of it as the caller's struct holds */
    clvox_status st = clvox__out_begin(ctx, info, sizeof *info, CLVOX__ELEMENT_INFO_SIZE_0, "clvox_palette_element_info");
    if (st != CLVOX_OK) return st;
    clvox_palette_element_info full;
    st = element_info_get(ctx, palette, index, &full);
    if (st == CLVOX_OK) clvox__out_end(info, &full);
    return st;
}

uint64_t clvox_palette_hash(const clvox_palette *p)
{
    if (!p) return 0;
    uint64_t h = clvox__fnv1a(CLVOX__FNV_BASIS, p->elements, p->count * sizeof *p->elements);
    h = clvox__fnv1a(h, p->cells, p->ncells * sizeof *p->cells);
    return clvox__fnv1a(h, p->planes, p->nplanes * sizeof *p->planes);
}

const char *clvox_palette_source(const clvox_palette *p) { return p ? p->source : NULL; }

const char *clvox_metric_name(clvox_metric m)
{
    static const char *const names[] = {"nearest", "outer", "inner"};
    return (unsigned)m < CLVOX_METRIC_COUNT ? names[m] : NULL;
}

/* ---- internal ---- */

void clvox__palette_arrays(const clvox_palette *p, const clvox_element **elements, size_t *element_count,
                           const clvox_cell **cells, size_t *cell_count, const clvox_halfspace **planes,
                           size_t *plane_count)
{
    *elements = p->elements;
    *element_count = p->count;
    *cells = p->cells;
    *cell_count = p->ncells;
    *planes = p->planes;
    *plane_count = p->nplanes;
}
