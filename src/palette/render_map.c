/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Render maps (Cavagnino & Gribaudo, section 4): which render object draws a
 * voxel of palette element E_v with score B_v. Each element gets an ordered
 * list of objects R_v,1 .. R_v,T with thresholds 1 = D_v,0 > D_v,1 > ... >
 * D_v,T = 0; R_v,j draws the voxel when D_v,j <= B_v < D_v,j-1, the top
 * interval closed, i.e. the first j with B_v >= D_v,j.
 *
 * File format (docs/design.md "Render maps, instances and Blender"): one
 * directive per line, '#' starts a comment, blank lines are ignored:
 *
 *     element NAME            rule for exactly this element; its objects are
 *                             modelled as the element itself (no symmetry)
 *     basic NAME              rule for the basic element NAME and every image
 *                             of it; objects modelled as NAME, instances
 *                             carry the image's symmetry S
 *     default                 rule for every element no other rule names
 *                             (modelled as the basic element, like basic)
 *     object OBJNAME D        next object of the rule above, threshold D
 *
 * Precedence: element, then basic, then default, then the built-in default:
 * one object named after the element's basic element. Names of elements are
 * the palette's (clvox palette show); object names are 1-63 of A-Z a-z 0-9 _
 * - . (so a CSV field never needs quoting). Thresholds are decimal numbers
 * (digits, an optional fraction, an optional exponent), read in the C locale
 * whatever the caller's is.
 *
 * Every malformed line is CLVOX_ERR_PALETTE_FORMAT "SOURCE:LINE: why". A rule
 * is checked when the next rule starts or the text ends: without objects it
 * is reported at its own line, with a last threshold other than 0 at that
 * object's line.
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "core/internal.h"
#include "palette/line_parser.h"

#include <errno.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RM_MAX_NAME 63u
#define RM_MAX_RULE_OBJECTS 256u
#define RM_MAX_OBJECTS 65536u
#define RM_MAX_FILE_BYTES (4u << 20)
#define RM_NONE 0xFFFFFFFFu

typedef struct rm_step {
    uint32_t object;
    double threshold;
} rm_step;

typedef struct rm_rule {
    uint32_t first, count; /* steps[first .. first+count-1] */
    unsigned line;         /* 0: built-in default */
    clvox_render_frame frame;
} rm_rule;

struct clvox_render_map {
    size_t element_count;
    uint32_t *rule_of; /* per element; RM_NONE for element 0 */
    rm_rule *rules;
    size_t nrules, caprules;
    rm_step *steps;
    size_t nsteps, capsteps;
    char (*names)[RM_MAX_NAME + 1];
    size_t nobjects, capobjects;
    uint32_t *hash; /* open addressing over names: object index or RM_NONE */
    size_t hashcap; /* power of two, > 2 * nobjects */
};

/* ---- building blocks --------------------------------------------------------- */

static uint64_t name_hash(const char *s) { return clvox__fnv1a(CLVOX__FNV_BASIS, s, strlen(s)); }

static int grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return 1;
    size_t n = *cap ? *cap : 16;
    while (n < need) n *= 2;
    void *q = realloc(*p, n * elem);
    if (!q) return 0;
    *p = q;
    *cap = n;
    return 1;
}

static int rehash(clvox_render_map *m, size_t cap)
{
    uint32_t *h = malloc(cap * sizeof *h);
    if (!h) return 0;
    for (size_t i = 0; i < cap; i++) h[i] = RM_NONE;
    for (size_t o = 0; o < m->nobjects; o++) {
        size_t at = (size_t)name_hash(m->names[o]) & (cap - 1);
        while (h[at] != RM_NONE) at = (at + 1) & (cap - 1);
        h[at] = (uint32_t)o;
    }
    free(m->hash);
    m->hash = h;
    m->hashcap = cap;
    return 1;
}

/* The index of object `name`, added when new. 0, or -1 out of memory, -2 too many objects. */
static int object_index(clvox_render_map *m, const char *name, uint32_t *out)
{
    if (m->hashcap) {
        size_t at = (size_t)name_hash(name) & (m->hashcap - 1);
        for (; m->hash[at] != RM_NONE; at = (at + 1) & (m->hashcap - 1))
            if (strcmp(m->names[m->hash[at]], name) == 0) {
                *out = m->hash[at];
                return 0;
            }
    }
    if (m->nobjects >= RM_MAX_OBJECTS) return -2;
    if (!grow((void **)&m->names, &m->capobjects, m->nobjects + 1, sizeof *m->names)) return -1;
    snprintf(m->names[m->nobjects], sizeof m->names[0], "%s", name);
    uint32_t idx = (uint32_t)m->nobjects++;
    if (2 * m->nobjects > m->hashcap) { /* rehash places the new name too */
        if (!rehash(m, m->hashcap ? 2 * m->hashcap : 64)) {
            m->nobjects--;
            return -1;
        }
    } else {
        size_t at = (size_t)name_hash(name) & (m->hashcap - 1);
        while (m->hash[at] != RM_NONE) at = (at + 1) & (m->hashcap - 1);
        m->hash[at] = idx;
    }
    *out = idx;
    return 0;
}

static int new_rule(clvox_render_map *m, unsigned line, clvox_render_frame frame, uint32_t *out)
{
    if (!grow((void **)&m->rules, &m->caprules, m->nrules + 1, sizeof *m->rules)) return 0;
    rm_rule *r = &m->rules[m->nrules];
    r->first = (uint32_t)m->nsteps;
    r->count = 0;
    r->line = line;
    r->frame = frame;
    *out = (uint32_t)m->nrules++;
    return 1;
}

static int add_step(clvox_render_map *m, uint32_t object, double threshold)
{
    if (!grow((void **)&m->steps, &m->capsteps, m->nsteps + 1, sizeof *m->steps)) return 0;
    m->steps[m->nsteps].object = object;
    m->steps[m->nsteps].threshold = threshold;
    m->nsteps++;
    m->rules[m->nrules - 1].count++;
    return 1;
}

static clvox_render_map *map_new(size_t element_count)
{
    clvox_render_map *m = calloc(1, sizeof *m);
    if (!m) return NULL;
    m->element_count = element_count;
    m->rule_of = malloc((element_count ? element_count : 1) * sizeof *m->rule_of);
    if (!m->rule_of) {
        free(m);
        return NULL;
    }
    for (size_t e = 0; e < element_count; e++) m->rule_of[e] = RM_NONE;
    return m;
}

void clvox_render_map_destroy(clvox_render_map *m)
{
    if (!m) return;
    free(m->rule_of);
    free(m->rules);
    free(m->steps);
    free(m->names);
    free(m->hash);
    free(m);
}

/* ---- the palette's names ------------------------------------------------------ */

typedef struct element_names {
    size_t count;
    char (*name)[64];
    uint32_t *basic;
} element_names;

static void names_free(element_names *n)
{
    free(n->name);
    free(n->basic);
}

static clvox_status names_get(clvox_context *ctx, const clvox_palette *palette, element_names *n)
{
    memset(n, 0, sizeof *n);
    n->count = clvox_palette_count(palette);
    if (n->count < 2)
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "render map: a palette of %zu elements", n->count);
    n->name = malloc(n->count * sizeof *n->name);
    n->basic = malloc(n->count * sizeof *n->basic);
    if (!n->name || !n->basic) {
        names_free(n);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "render map: out of memory");
    }
    for (size_t e = 0; e < n->count; e++) {
        clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        clvox_status st = clvox_palette_element_info_get(ctx, palette, e, &info);
        if (st != CLVOX_OK) {
            names_free(n);
            return st;
        }
        memcpy(n->name[e], info.name, sizeof n->name[e]);
        n->name[e][sizeof n->name[e] - 1] = '\0';
        n->basic[e] = info.basic < n->count ? info.basic : (uint32_t)e;
    }
    return CLVOX_OK;
}

static uint32_t find_element(const element_names *n, const char *name)
{
    for (size_t e = 0; e < n->count; e++)
        if (strcmp(n->name[e], name) == 0) return (uint32_t)e;
    return RM_NONE;
}

/* Elements without a rule get the default rule, else one object named after
 * their basic element (one shared rule per basic element). */
static clvox_status fill_defaults(clvox_context *ctx, clvox_render_map *m, const element_names *n,
                                  uint32_t default_rule)
{
    uint32_t *implicit = malloc(n->count * sizeof *implicit);
    if (!implicit) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "render map: out of memory");
    for (size_t e = 0; e < n->count; e++) implicit[e] = RM_NONE;
    clvox_status st = CLVOX_OK;
    for (size_t e = 1; e < n->count && st == CLVOX_OK; e++) {
        if (m->rule_of[e] != RM_NONE) continue;
        if (default_rule != RM_NONE) {
            m->rule_of[e] = default_rule;
            continue;
        }
        uint32_t b = n->basic[e];
        if (implicit[b] == RM_NONE) {
            uint32_t obj = 0, r = 0;
            int got = object_index(m, n->name[b], &obj);
            if (got == -2)
                st = clvox__fail(ctx, CLVOX_ERR_PALETTE_FORMAT, "render map: more than %u objects", RM_MAX_OBJECTS);
            else if (got != 0 || !new_rule(m, 0, CLVOX_RENDER_FRAME_BASIC, &r) || !add_step(m, obj, 0.0))
                st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "render map: out of memory");
            else implicit[b] = r;
        }
        m->rule_of[e] = implicit[b];
    }
    free(implicit);
    return st;
}

/* ---- parsing ------------------------------------------------------------------- */

typedef enum rule_kind { KIND_ELEMENT, KIND_BASIC, KIND_DEFAULT } rule_kind;

typedef struct parser {
    clvox__line_parser lp; /* context, source and line, for messages */
    const char *palette_name;
    clvox_render_map *m;
    const element_names *n;
    /* the open rule */
    int open;
    uint32_t rule;
    unsigned last_object_line;
    char what[96];             /* "element 'wedge_s3'", "basic 'wedge'", "default" */
    /* who has a rule, and at which line */
    unsigned *element_line;    /* per element: line of its `element` rule, 0 none */
    unsigned *basic_line;      /* per element: line of its `basic` rule, 0 none */
    uint32_t *basic_rule;      /* per basic element: its rule */
    unsigned default_line;
    uint32_t default_rule;
} parser;

#define PFAIL(ps, ...) clvox__line_fail(&(ps)->lp, __VA_ARGS__)

static clvox_status oom(parser *ps) { return clvox__fail(ps->lp.ctx, CLVOX_ERR_OUT_OF_MEMORY, "render map: out of memory"); }

static int valid_name(const char *s) { return clvox__line_valid_name(s, RM_MAX_NAME); }

/* A decimal number: digits with an optional fraction (at least one digit in
 * all) and an optional exponent; nothing else (no sign, hex, inf, nan). */
static int parse_threshold(const char *s, double *out)
{
    const char *p = s;
    int digits = 0;
    while (*p >= '0' && *p <= '9') p++, digits++;
    if (*p == '.') {
        p++;
        while (*p >= '0' && *p <= '9') p++, digits++;
    }
    if (!digits) return 0;
    if (*p == 'e' || *p == 'E') {
        p++;
        if (*p == '+' || *p == '-') p++;
        if (!(*p >= '0' && *p <= '9')) return 0;
        while (*p >= '0' && *p <= '9') p++;
    }
    if (*p) return 0;
    char *end = NULL;
    errno = 0;
    double v = strtod(s, &end); /* the caller runs this under the C locale */
    if (!end || *end || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

/* The shortest "%.Ng" text that reads back as v (thresholds in messages). */
static const char *num(char *buf, size_t size, double v)
{
    for (int p = 1; p <= 17; p++) {
        snprintf(buf, size, "%.*g", p, v);
        if (strtod(buf, NULL) == v) break;
    }
    return buf;
}

/* The open rule is complete: it has objects and its last threshold is 0. */
static clvox_status close_rule(parser *ps)
{
    if (!ps->open) return CLVOX_OK;
    ps->open = 0;
    const rm_rule *r = &ps->m->rules[ps->rule];
    unsigned line = ps->lp.line;
    clvox_status st = CLVOX_OK;
    if (r->count == 0) {
        ps->lp.line = r->line;
        st = PFAIL(ps, "%s has no 'object' line", ps->what);
    } else if (ps->m->steps[r->first + r->count - 1].threshold != 0.0) {
        ps->lp.line = ps->last_object_line;
        char b[32];
        st = PFAIL(ps, "the last object of %s has threshold %s: the last threshold must be 0", ps->what,
                        num(b, sizeof b, ps->m->steps[r->first + r->count - 1].threshold));
    }
    ps->lp.line = line;
    return st;
}

static clvox_status open_rule(parser *ps, rule_kind kind, uint32_t element)
{
    clvox_status st = close_rule(ps);
    if (st != CLVOX_OK) return st;
    uint32_t r = 0;
    if (!new_rule(ps->m, ps->lp.line, kind == KIND_ELEMENT ? CLVOX_RENDER_FRAME_ELEMENT : CLVOX_RENDER_FRAME_BASIC, &r))
        return oom(ps);
    ps->open = 1;
    ps->rule = r;
    if (kind == KIND_ELEMENT) {
        ps->element_line[element] = ps->lp.line;
        ps->m->rule_of[element] = r;
        snprintf(ps->what, sizeof ps->what, "element '%s'", ps->n->name[element]);
    } else if (kind == KIND_BASIC) {
        ps->basic_line[element] = ps->lp.line;
        ps->basic_rule[element] = r;
        snprintf(ps->what, sizeof ps->what, "basic '%s'", ps->n->name[element]);
    } else {
        ps->default_line = ps->lp.line;
        ps->default_rule = r;
        snprintf(ps->what, sizeof ps->what, "default");
    }
    return CLVOX_OK;
}

static clvox_status rule_line(parser *ps, rule_kind kind, const char *name)
{
    if (!valid_name(name)) return PFAIL(ps, "bad element name '%.64s'", name);
    uint32_t e = find_element(ps->n, name);
    if (e == RM_NONE)
        return PFAIL(ps, "no element '%s' in palette '%.64s' (see clvox palette show)", name, ps->palette_name);
    if (e == 0) return PFAIL(ps, "'%s' is the empty element: empty voxels are not drawn", name);
    if (kind == KIND_ELEMENT) {
        if (ps->element_line[e]) return PFAIL(ps, "element '%s' already has a rule (line %u)", name, ps->element_line[e]);
    } else {
        uint32_t b = ps->n->basic[e];
        if (b != e)
            return PFAIL(ps, "'%s' is not a basic element: it is an image of '%s' (use 'element %s' or 'basic %s')",
                              name, ps->n->name[b], name, ps->n->name[b]);
        if (ps->basic_line[e]) return PFAIL(ps, "basic '%s' already has a rule (line %u)", name, ps->basic_line[e]);
    }
    return open_rule(ps, kind, e);
}

static clvox_status object_line(parser *ps, const char *name, const char *value)
{
    if (!ps->open) return PFAIL(ps, "'object' before any 'element', 'basic' or 'default' line");
    if (!valid_name(name))
        return PFAIL(ps, "bad object name '%.64s' (1-%u characters of A-Z a-z 0-9 _ - .)", name, RM_MAX_NAME);
    double d = 0;
    if (!parse_threshold(value, &d)) return PFAIL(ps, "threshold '%.64s' is not a decimal number", value);
    char b1[32], b2[32];
    if (!(d < 1.0)) return PFAIL(ps, "threshold %s is not below 1 (D_0 = 1)", num(b1, sizeof b1, d));
    const rm_rule *r = &ps->m->rules[ps->rule];
    if (r->count) {
        double prev = ps->m->steps[r->first + r->count - 1].threshold;
        if (prev == 0.0)
            return PFAIL(ps, "%s already ended with threshold 0 (line %u): nothing can follow it", ps->what,
                              ps->last_object_line);
        if (!(d < prev))
            return PFAIL(ps, "threshold %s is not below the previous one, %s (thresholds decrease "
                              "strictly to 0)", num(b1, sizeof b1, d), num(b2, sizeof b2, prev));
    }
    if (r->count >= RM_MAX_RULE_OBJECTS) return PFAIL(ps, "more than %u objects in %s", RM_MAX_RULE_OBJECTS, ps->what);
    uint32_t obj = 0;
    int got = object_index(ps->m, name, &obj);
    if (got == -2) return PFAIL(ps, "more than %u distinct objects", RM_MAX_OBJECTS);
    if (got != 0 || !add_step(ps->m, obj, d)) return oom(ps);
    ps->last_object_line = ps->lp.line;
    return CLVOX_OK;
}

/* One line's fields (clvox__parse_lines: the comment removed, at most 4). */
static clvox_status parse_line(void *user, char **tok, int n)
{
    parser *ps = user;
    const char *kw = tok[0];
    if (strcmp(kw, "element") == 0 || strcmp(kw, "basic") == 0) {
        if (n != 2) return PFAIL(ps, "'%s' takes one element name", kw);
        return rule_line(ps, kw[0] == 'e' ? KIND_ELEMENT : KIND_BASIC, tok[1]);
    }
    if (strcmp(kw, "default") == 0) {
        if (n != 1) return PFAIL(ps, "'default' takes no arguments");
        if (ps->default_line) return PFAIL(ps, "'default' given twice (line %u)", ps->default_line);
        return open_rule(ps, KIND_DEFAULT, 0);
    }
    if (strcmp(kw, "object") == 0) {
        if (n != 3) return PFAIL(ps, "'object' takes a name and a threshold ('object NAME D'), got %d fields", n - 1);
        return object_line(ps, tok[1], tok[2]);
    }
    return PFAIL(ps, "unknown directive '%.64s' (element, basic, default, object)", kw);
}

static clvox_status parse_text(parser *ps, const char *text, size_t size)
{
    clvox_status st = clvox__parse_lines(&ps->lp, "render map", text, size, 4, parse_line, ps);
    if (st == CLVOX_OK) st = close_rule(ps);
    return st;
}

clvox_status clvox_render_map_parse(clvox_context *ctx, const char *source, const char *text, size_t size,
                                    const clvox_palette *palette, clvox_render_map **out)
{
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_render_map_parse: out is NULL");
    *out = NULL;
    if (!palette) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_render_map_parse: no palette");
    if (!text && size) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_render_map_parse: text is NULL");
    if (!source) source = "render map";
    element_names n;
    clvox_status st = names_get(ctx, palette, &n);
    if (st != CLVOX_OK) return st;
    parser ps;
    memset(&ps, 0, sizeof ps);
    ps.lp.ctx = ctx;
    ps.lp.source = source;
    ps.palette_name = clvox_palette_name(palette);
    ps.n = &n;
    ps.default_rule = RM_NONE;
    ps.m = map_new(n.count);
    ps.element_line = calloc(n.count, sizeof *ps.element_line);
    ps.basic_line = calloc(n.count, sizeof *ps.basic_line);
    ps.basic_rule = malloc(n.count * sizeof *ps.basic_rule);
    locale_t c_locale = (locale_t)0, old = (locale_t)0;
    if (!ps.m || !ps.element_line || !ps.basic_line || !ps.basic_rule) st = oom(&ps);
    if (st == CLVOX_OK) {
        c_locale = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
        if (!c_locale) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "render map: cannot create the C locale");
    }
    if (st == CLVOX_OK) {
        for (size_t e = 0; e < n.count; e++) ps.basic_rule[e] = RM_NONE;
        old = uselocale(c_locale);
        st = parse_text(&ps, text, size);
        uselocale(old);
    }
    if (c_locale) freelocale(c_locale);
    /* basic rules for the elements without an element rule */
    for (size_t e = 1; st == CLVOX_OK && e < n.count; e++)
        if (ps.m->rule_of[e] == RM_NONE && ps.basic_rule[n.basic[e]] != RM_NONE)
            ps.m->rule_of[e] = ps.basic_rule[n.basic[e]];
    if (st == CLVOX_OK) st = fill_defaults(ctx, ps.m, &n, ps.default_rule);
    free(ps.element_line);
    free(ps.basic_line);
    free(ps.basic_rule);
    names_free(&n);
    if (st != CLVOX_OK) {
        clvox_render_map_destroy(ps.m);
        return st;
    }
    *out = ps.m;
    return CLVOX_OK;
}

clvox_status clvox_render_map_load(clvox_context *ctx, const char *path, const clvox_palette *palette,
                                   clvox_render_map **out)
{
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_render_map_load: out is NULL");
    *out = NULL;
    if (!path) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_render_map_load: path is NULL");
    char *data = NULL;
    size_t n = 0;
    clvox_status st = clvox__read_text_file(ctx, path, "render map", RM_MAX_FILE_BYTES, &data, &n);
    if (st == CLVOX_OK) st = clvox_render_map_parse(ctx, path, data, n, palette, out);
    free(data);
    return st;
}

clvox_status clvox_render_map_default(clvox_context *ctx, const clvox_palette *palette, clvox_render_map **out)
{
    if (!out) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_render_map_default: out is NULL");
    *out = NULL;
    if (!palette) return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "clvox_render_map_default: no palette");
    element_names n;
    clvox_status st = names_get(ctx, palette, &n);
    if (st != CLVOX_OK) return st;
    clvox_render_map *m = map_new(n.count);
    if (!m) st = clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "render map: out of memory");
    if (st == CLVOX_OK) st = fill_defaults(ctx, m, &n, RM_NONE);
    names_free(&n);
    if (st != CLVOX_OK) {
        clvox_render_map_destroy(m);
        return st;
    }
    *out = m;
    return CLVOX_OK;
}

/* ---- queries --------------------------------------------------------------------- */

size_t clvox_render_map_object_count(const clvox_render_map *m) { return m ? m->nobjects : 0; }

const char *clvox_render_map_object_name(const clvox_render_map *m, size_t object)
{
    return m && object < m->nobjects ? m->names[object] : NULL;
}

uint32_t clvox_render_map_choose(const clvox_render_map *m, uint32_t element, double score,
                                 clvox_render_frame *frame)
{
    if (!m || element == 0 || element >= m->element_count || m->rule_of[element] == RM_NONE)
        return CLVOX_PALETTE_NONE;
    const rm_rule *r = &m->rules[m->rule_of[element]];
    if (frame) *frame = r->frame;
    const rm_step *s = m->steps + r->first;
    for (uint32_t j = 0; j + 1 < r->count; j++)
        if (score >= s[j].threshold) return s[j].object;
    return s[r->count - 1].object; /* threshold 0: every score >= 0, and below 0 or NaN too */
}

unsigned clvox_render_map_rule_line(const clvox_render_map *m, uint32_t element)
{
    if (!m || element == 0 || element >= m->element_count || m->rule_of[element] == RM_NONE) return 0;
    return m->rules[m->rule_of[element]].line;
}
