/* SPDX-License-Identifier: Apache-2.0 */
/* Past 800 lines on purpose: one test program per command; its cases share the
 * render-map and volume fixtures. */
/* Render maps and `clvox instances`:
 *  - the thresholds rule of Cavagnino & Gribaudo (section 4) at the ends of
 *    its intervals (B = 1, B exactly a threshold, just below one, B = 0, and
 *    out-of-range scores), the precedence of element / basic / default rules
 *    and the built-in default, the shipped example maps;
 *  - every malformed render map line with its line number;
 *  - the CLI ($CLVOX_BIN) on volumes written by tests/exrgen.c (element UINT,
 *    score HALF): one row per non-empty voxel and none else, every field
 *    against what the volume holds (world centre, voxel size, names, the
 *    symmetry S of clvox_palette_element_info_get, score, object, frame),
 *    several slices, errors (bad map with its line, values that are no
 *    element, scores outside [0,1], missing channels, outputs that cannot be
 *    written) with one-line messages and no file left behind;
 *  - end to end: a mesh voxelized with --palette (paper46, paper78,
 *    palettes/blocks.txt) through the CLI, then instances with the palette
 *    from the header, against the volume's own element and score channels;
 *    a --palette other than the header's refused. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* realpath, symlink */
#endif
#include "exrgen.h"
#include "spawn.h"
#include "testio.h"
#include "test.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <locale.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static clvox_context *g_ctx;
static char g_bin[PATH_MAX];
static char g_dir[PATH_MAX]; /* <tmp>/instances */
static char g_out[PATH_MAX]; /* outputs of runs that must fail: stays empty */

#define ARGS(...) ((const char *const[]){g_bin, __VA_ARGS__, NULL})

/* ---- render maps -------------------------------------------------------------------- */

static clvox_palette *builtin(const char *name)
{
    clvox_palette *p = NULL;
    CHECK_OK(g_ctx, clvox_palette_builtin(g_ctx, name, &p));
    if (!p) abort();
    return p;
}

static uint32_t index_of(const clvox_palette *p, const char *name)
{
    for (size_t e = 0; e < clvox_palette_count(p); e++) {
        clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        if (clvox_palette_element_info_get(g_ctx, p, e, &info) == CLVOX_OK && strcmp(info.name, name) == 0)
            return (uint32_t)e;
    }
    fprintf(stderr, "no element %s\n", name);
    abort();
}

static clvox_render_map *parse(const clvox_palette *p, const char *text)
{
    clvox_render_map *m = NULL;
    clvox_status st = clvox_render_map_parse(g_ctx, "t.render", text, strlen(text), p, &m);
    CHECK_MSG(st == CLVOX_OK && m, "%s: %s", text, clvox_context_error(g_ctx));
    return m;
}

/* The name of the object chosen for (element name, score); "" for none. */
static const char *chosen(const clvox_render_map *m, const clvox_palette *p, const char *element, double score,
                          clvox_render_frame *frame)
{
    uint32_t o = clvox_render_map_choose(m, index_of(p, element), score, frame);
    const char *n = clvox_render_map_object_name(m, o);
    return n ? n : "";
}

#define CHOSEN(m, p, e, b, want) do { \
    const char *got_ = chosen(m, p, e, b, NULL); \
    CHECK_MSG(strcmp(got_, want) == 0, "%s at B = %.17g: got '%s', want '%s'", e, (double)(b), got_, want); \
} while (0)

static void test_thresholds(void)
{
    clvox_palette *p = builtin("paper46");
    clvox_render_map *m = parse(p, "element wedge\n  object a 0.75\n  object b 0.5\n  object c 0\n");
    if (!m) return;
    CHOSEN(m, p, "wedge", 1.0, "a");                     /* the top interval is closed */
    CHOSEN(m, p, "wedge", 0.9, "a");
    CHOSEN(m, p, "wedge", 0.75, "a");                    /* B = D_1: object 1 (D_1 <= B < D_0) */
    CHOSEN(m, p, "wedge", nextafter(0.75, 0.0), "b");    /* just below D_1 */
    CHOSEN(m, p, "wedge", 0.5, "b");                     /* B = D_2 */
    CHOSEN(m, p, "wedge", nextafter(0.5, 0.0), "c");
    CHOSEN(m, p, "wedge", 0.25, "c");
    CHOSEN(m, p, "wedge", 0.0, "c");                     /* B = 0 = D_T */
    CHOSEN(m, p, "wedge", 1.5, "a");                     /* out of range: clamped */
    CHOSEN(m, p, "wedge", -0.5, "c");
    CHOSEN(m, p, "wedge", NAN, "c");
    /* a float score exactly at a threshold, as the volume hands it over */
    CHOSEN(m, p, "wedge", (double)0.75f, "a");
    CHOSEN(m, p, "wedge", (double)nextafterf(0.75f, 0.0f), "b");
    clvox_render_frame f = CLVOX_RENDER_FRAME_BASIC;
    (void)chosen(m, p, "wedge", 1.0, &f);
    CHECK(f == CLVOX_RENDER_FRAME_ELEMENT);
    CHECK(clvox_render_map_rule_line(m, index_of(p, "wedge")) == 1);
    /* empty and indices past the palette: nothing */
    CHECK(clvox_render_map_choose(m, 0, 1.0, NULL) == CLVOX_PALETTE_NONE);
    CHECK(clvox_render_map_choose(m, 46, 1.0, NULL) == CLVOX_PALETTE_NONE);
    CHECK(clvox_render_map_choose(NULL, 2, 1.0, NULL) == CLVOX_PALETTE_NONE);
    CHECK(clvox_render_map_object_name(m, clvox_render_map_object_count(m)) == NULL);
    clvox_render_map_destroy(m);

    /* one object: every score */
    m = parse(p, "element corner\nobject only 0\n");
    if (m) {
        CHOSEN(m, p, "corner", 1.0, "only");
        CHOSEN(m, p, "corner", 0.0, "only");
        clvox_render_map_destroy(m);
    }
    /* a threshold just below 1, one far below: exact decimal reading */
    m = parse(p, "element corner\nobject top 0.99999999999999989\nobject rest 1e-300\nobject zero 0.0e5\n");
    if (m) {
        CHOSEN(m, p, "corner", 1.0, "top");
        CHOSEN(m, p, "corner", 0.9999999999999998, "rest");
        CHOSEN(m, p, "corner", 1e-300, "rest");
        CHOSEN(m, p, "corner", 0.0, "zero");
        clvox_render_map_destroy(m);
    }
    clvox_palette_destroy(p);
}

static void test_precedence(void)
{
    clvox_palette *p = builtin("paper46");
    clvox_render_map *m = parse(p, "basic wedge   # every wedge image\n"
                                   "  object w 0\n"
                                   "element wedge_s3\n"
                                   "  object x 0\n"
                                   "default\n"
                                   "  object d 0\n");
    if (m) {
        clvox_render_frame f = CLVOX_RENDER_FRAME_ELEMENT;
        CHECK(strcmp(chosen(m, p, "wedge", 1, &f), "w") == 0 && f == CLVOX_RENDER_FRAME_BASIC);
        CHECK(strcmp(chosen(m, p, "wedge_s1", 1, &f), "w") == 0 && f == CLVOX_RENDER_FRAME_BASIC);
        CHECK(strcmp(chosen(m, p, "wedge_s38", 0.5, &f), "w") == 0 && f == CLVOX_RENDER_FRAME_BASIC);
        CHECK(strcmp(chosen(m, p, "wedge_s3", 1, &f), "x") == 0 && f == CLVOX_RENDER_FRAME_ELEMENT);
        CHECK(strcmp(chosen(m, p, "corner_s5", 1, &f), "d") == 0 && f == CLVOX_RENDER_FRAME_BASIC);
        CHECK(strcmp(chosen(m, p, "full", 1, &f), "d") == 0);
        CHECK(clvox_render_map_rule_line(m, index_of(p, "wedge_s1")) == 1);
        CHECK(clvox_render_map_rule_line(m, index_of(p, "wedge_s3")) == 3);
        CHECK(clvox_render_map_rule_line(m, index_of(p, "roof")) == 5);
        CHECK(clvox_render_map_object_count(m) == 3);
        clvox_render_map_destroy(m);
    }
    /* without default: the basic element's name, frame basic */
    m = parse(p, "element full\n object crate 0\nelement wedge\n object crate 0\n");
    if (m) {
        clvox_render_frame f = CLVOX_RENDER_FRAME_ELEMENT;
        CHECK(strcmp(chosen(m, p, "corner_s5", 1, &f), "corner") == 0 && f == CLVOX_RENDER_FRAME_BASIC);
        CHECK(strcmp(chosen(m, p, "wedge_s1", 0.2, &f), "wedge") == 0 && f == CLVOX_RENDER_FRAME_BASIC);
        CHECK(strcmp(chosen(m, p, "wedge", 0.2, &f), "crate") == 0 && f == CLVOX_RENDER_FRAME_ELEMENT);
        CHECK(clvox_render_map_rule_line(m, index_of(p, "corner_s5")) == 0);
        /* one name, one object: crate (both rules), then wedge, roof, column, corner */
        CHECK(clvox_render_map_object_count(m) == 5);
        CHECK(strcmp(clvox_render_map_object_name(m, 0), "crate") == 0);
        clvox_render_map_destroy(m);
    }
    /* the built-in default map: one object per basic element, in palette order */
    m = NULL;
    CHECK_OK(g_ctx, clvox_render_map_default(g_ctx, p, &m));
    if (m) {
        static const char *const basics[] = {"full", "wedge", "roof", "column", "corner"};
        CHECK(clvox_render_map_object_count(m) == 5);
        for (size_t i = 0; i < 5; i++) {
            const char *n = clvox_render_map_object_name(m, i);
            CHECK_MSG(n && strcmp(n, basics[i]) == 0, "object %zu: %s", i, n ? n : "NULL");
        }
        for (uint32_t e = 1; e < 46; e++) {
            clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT, basic = CLVOX_PALETTE_ELEMENT_INFO_INIT;
            CHECK_OK(g_ctx, clvox_palette_element_info_get(g_ctx, p, e, &info));
            CHECK_OK(g_ctx, clvox_palette_element_info_get(g_ctx, p, info.basic, &basic));
            clvox_render_frame f = CLVOX_RENDER_FRAME_ELEMENT;
            const char *n = clvox_render_map_object_name(m, clvox_render_map_choose(m, e, 0.3, &f));
            CHECK_MSG(n && strcmp(n, basic.name) == 0 && f == CLVOX_RENDER_FRAME_BASIC, "element %u", e);
        }
        clvox_render_map_destroy(m);
    }
    /* comments, CRLF, tabs, blank lines, an empty map */
    m = parse(p, "# a map\r\n\r\n\telement\tfull # the full voxel\r\n\t\tobject\ta.b-c_1\t0.5\r\n object z 0\r\n");
    if (m) {
        CHOSEN(m, p, "full", 0.5, "a.b-c_1");
        CHOSEN(m, p, "full", 0.4, "z");
        clvox_render_map_destroy(m);
    }
    m = parse(p, "");
    if (m) {
        CHOSEN(m, p, "roof_s4", 1, "roof");
        clvox_render_map_destroy(m);
    }
    clvox_palette_destroy(p);
}

static void test_examples(void)
{
    clvox_palette *p46 = builtin("paper46"), *p78 = builtin("paper78"), *blocks = NULL;
    CHECK_OK(g_ctx, clvox_palette_load(g_ctx, "palettes/blocks.txt", &blocks));
    clvox_render_map *m = NULL;
    CHECK_OK(g_ctx, clvox_render_map_load(g_ctx, "palettes/paper46.render", p46, &m));
    if (m) {
        CHOSEN(m, p46, "corner_s3", 0.6, "pyramid"); /* the paper's example: D = 0.6 */
        CHOSEN(m, p46, "corner_s3", 0.59, "ice_cream_cone");
        CHOSEN(m, p46, "full", 1.0, "crate");
        CHOSEN(m, p46, "wedge_s9", 0.1, "door_stop");
        clvox_render_map_destroy(m);
    }
    m = NULL;
    CHECK_OK(g_ctx, clvox_render_map_load(g_ctx, "palettes/paper46.render", p78, &m));
    if (m) {
        CHOSEN(m, p78, "not_roof_s4", 0.9, "rubble");
        CHOSEN(m, p78, "roof_s4", 0.9, "tent");
        clvox_render_map_destroy(m);
    }
    m = NULL;
    if (blocks) CHECK_OK(g_ctx, clvox_render_map_load(g_ctx, "palettes/blocks.render", blocks, &m));
    if (m) {
        CHOSEN(m, blocks, "full", 1.0, "stone");
        CHOSEN(m, blocks, "full", 0.6, "cobblestone");
        CHOSEN(m, blocks, "full", 0.59, "mossy_cobblestone");
        CHOSEN(m, blocks, "stairs_down_west", 0.1, "stone_stairs_down_west");
        for (uint32_t e = 1; e < clvox_palette_count(blocks); e++)
            CHECK_MSG(clvox_render_map_rule_line(m, e) != 0, "blocks element %u not mapped", e);
        clvox_render_map_destroy(m);
    }
    /* the blocks map names blocks.txt's elements: not paper46's */
    m = NULL;
    CHECK_STATUS(g_ctx, clvox_render_map_load(g_ctx, "palettes/blocks.render", p46, &m), CLVOX_ERR_PALETTE_FORMAT);
    CHECK(m == NULL);
    CHECK(strstr(clvox_context_error(g_ctx), "palettes/blocks.render:19: no element 'slab_bottom' in palette 'paper46'"));
    /* unreadable */
    CHECK_STATUS(g_ctx, clvox_render_map_load(g_ctx, "no/such.render", p46, &m), CLVOX_ERR_IO);
    CHECK(m == NULL && strstr(clvox_context_error(g_ctx), "no/such.render"));
    /* bad arguments */
    CHECK_STATUS(g_ctx, clvox_render_map_parse(g_ctx, "x", "", 0, NULL, &m), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(g_ctx, clvox_render_map_parse(g_ctx, "x", NULL, 3, p46, &m), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(g_ctx, clvox_render_map_parse(g_ctx, "x", "", 0, p46, NULL), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(g_ctx, clvox_render_map_default(g_ctx, NULL, &m), CLVOX_ERR_INVALID_ARGUMENT);
    clvox_render_map_destroy(NULL);
    /* a comma as the decimal point in the caller's locale changes nothing */
    const char *de = setlocale(LC_NUMERIC, "de_DE.UTF-8");
    if (!de) de = setlocale(LC_NUMERIC, "fr_FR.UTF-8");
    m = parse(p46, "element full\nobject a 0.5\nobject b 0\n");
    if (m) {
        CHOSEN(m, p46, "full", 0.5, "a");
        CHOSEN(m, p46, "full", 0.4, "b");
        clvox_render_map_destroy(m);
    }
    setlocale(LC_NUMERIC, "C");
    printf("locale test with %s\n", de ? de : "the C locale only (no other locale installed)");
    clvox_palette_destroy(blocks);
    clvox_palette_destroy(p78);
    clvox_palette_destroy(p46);
}

typedef struct bad_map {
    const char *text;
    const char *message; /* after "t.render:" */
} bad_map;

static void test_map_errors(void)
{
    static const bad_map cases[] = {
        {"frobnicate x\n", "1: unknown directive 'frobnicate' (element, basic, default, object)"},
        {"element\n", "1: 'element' takes one element name"},
        {"basic a b\n", "1: 'basic' takes one element name"},
        {"\n# x\nelement nope\n", "3: no element 'nope' in palette 'paper46' (see clvox palette show)"},
        {"element a/b\n", "1: bad element name 'a/b'"},
        {"element empty\n object a 0\n", "1: 'empty' is the empty element: empty voxels are not drawn"},
        {"basic empty\n", "1: 'empty' is the empty element: empty voxels are not drawn"},
        {"basic wedge_s3\n object a 0\n",
         "1: 'wedge_s3' is not a basic element: it is an image of 'wedge' (use 'element wedge_s3' or 'basic wedge')"},
        {"object a 0\n", "1: 'object' before any 'element', 'basic' or 'default' line"},
        {"element full\n object a 0\nelement full\n object b 0\n", "3: element 'full' already has a rule (line 1)"},
        {"basic wedge\n object a 0\nbasic wedge\n object a 0\n", "3: basic 'wedge' already has a rule (line 1)"},
        {"default\n object a 0\n\ndefault\n", "4: 'default' given twice (line 1)"},
        {"default x\n", "1: 'default' takes no arguments"},
        {"element full\n object a\n", "2: 'object' takes a name and a threshold ('object NAME D'), got 1 fields"},
        {"element full\n object a b c d\n", "2: too many fields"},
        {"element full\n object a/b 0\n", "2: bad object name 'a/b' (1-63 characters of A-Z a-z 0-9 _ - .)"},
        {"element full\n object "
         "a123456789012345678901234567890123456789012345678901234567890123 0\n",
         "2: bad object name"},
        {"element full\n object a 1\n", "2: threshold 1 is not below 1 (D_0 = 1)"},
        {"element full\n object a 1.5\n", "2: threshold 1.5 is not below 1 (D_0 = 1)"},
        {"element full\n object a -0.5\n", "2: threshold '-0.5' is not a decimal number"},
        {"element full\n object a +0.5\n", "2: threshold '+0.5' is not a decimal number"},
        {"element full\n object a 0x1\n", "2: threshold '0x1' is not a decimal number"},
        {"element full\n object a nan\n", "2: threshold 'nan' is not a decimal number"},
        {"element full\n object a inf\n", "2: threshold 'inf' is not a decimal number"},
        {"element full\n object a 1e\n", "2: threshold '1e' is not a decimal number"},
        {"element full\n object a .\n", "2: threshold '.' is not a decimal number"},
        {"element full\n object a 0,5\n", "2: threshold '0,5' is not a decimal number"},
        {"element full\n object a 1e999\n", "2: threshold '1e999' is not a decimal number"},
        {"element full\n object a 0.5\n object b 0.5\n",
         "3: threshold 0.5 is not below the previous one, 0.5 (thresholds decrease strictly to 0)"},
        {"element full\n object a 0.5\n object b 0.75\n",
         "3: threshold 0.75 is not below the previous one, 0.5 (thresholds decrease strictly to 0)"},
        {"element full\n object a 0\n object b 0\n",
         "3: element 'full' already ended with threshold 0 (line 2): nothing can follow it"},
        {"element full\n object a 0.5\n\n# end\n",
         "2: the last object of element 'full' has threshold 0.5: the last threshold must be 0"},
        {"basic wedge\n object a 0.25\nelement full\n object b 0\n",
         "2: the last object of basic 'wedge' has threshold 0.25: the last threshold must be 0"},
        {"default\n object a 0.5\n object b 0.125\n",
         "3: the last object of default has threshold 0.125: the last threshold must be 0"},
        {"element full\nelement wedge\n object a 0\n", "1: element 'full' has no 'object' line"},
        {"element wedge\n object a 0\nelement full", "3: element 'full' has no 'object' line"},
        {"default\n", "1: default has no 'object' line"},
    };
    clvox_palette *p = builtin("paper46");
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        clvox_render_map *m = (clvox_render_map *)&m; /* must be cleared */
        clvox_status st = clvox_render_map_parse(g_ctx, "t.render", cases[i].text, strlen(cases[i].text), p, &m);
        const char *msg = clvox_context_error(g_ctx);
        char want[512];
        snprintf(want, sizeof want, "t.render:%s", cases[i].message);
        CHECK_MSG(st == CLVOX_ERR_PALETTE_FORMAT && m == NULL && strncmp(msg, want, strlen(want)) == 0 &&
                      !strchr(msg, '\n'),
                  "case %zu: %s\n  got:  %s\n  want: %s", i, clvox_status_string(st), msg, want);
        if (st == CLVOX_OK) clvox_render_map_destroy(m);
    }
    /* a NUL byte */
    static const char nul[] = "element full\n\0object a 0\n";
    clvox_render_map *m = NULL;
    CHECK_STATUS(g_ctx, clvox_render_map_parse(g_ctx, "t.render", nul, sizeof nul - 1, p, &m), CLVOX_ERR_PALETTE_FORMAT);
    CHECK(strcmp(clvox_context_error(g_ctx), "t.render:2: NUL byte (not a text file)") == 0);
    /* the file's path names the errors of a loaded map */
    char path[PATH_MAX];
    path_join(path, sizeof path, g_dir, "bad.render");
    CHECK(write_text(path, "element full\n object a 0\n\nobject b 0\n"));
    CHECK_STATUS(g_ctx, clvox_render_map_load(g_ctx, path, p, &m), CLVOX_ERR_PALETTE_FORMAT);
    char want[PATH_MAX + 64];
    snprintf(want, sizeof want, "%s:4: element 'full' already ended with threshold 0 (line 2)", path);
    CHECK_MSG(strncmp(clvox_context_error(g_ctx), want, strlen(want)) == 0, "%s", clvox_context_error(g_ctx));
    clvox_palette_destroy(p);
}

/* ---- the CLI on hand-made volumes ------------------------------------------------------ */

/* HALF bits of a few exact values. */
#define H_0 0x0000u
#define H_QUARTER 0x3400u
#define H_HALF 0x3800u
#define H_060 0x38CDu /* 0.60009765625 */
#define H_075 0x3A00u
#define H_ONE 0x3C00u
#define H_1_5 0x3E00u

static int make_volume(const char *path, uint32_t X, uint32_t Y, uint32_t Z, const uint32_t *element,
                       const uint16_t *score)
{
    exrgen_channel ch[2];
    int n = 0;
    if (element) ch[n++] = (exrgen_channel){"element", EXR_PIXEL_UINT, element};
    if (score) ch[n++] = (exrgen_channel){"score", EXR_PIXEL_HALF, score};
    return exrgen_write(path, X, Y, Z, ch, n, 0, 0, EXR_COMPRESSION_ZIP, 1);
}

typedef struct csv_row {
    unsigned i, j, k;
    double x, y, z, hx, hy, hz;
    unsigned element;
    char name[64], basic[64];
    int s[9];
    float score;
    char object[64], frame[16];
} csv_row;

/* Parses the rows after the header; returns the row count or -1. */
static int parse_csv(const char *text, csv_row *rows, int cap)
{
    static const char header[] =
        "i,j,k,x,y,z,hx,hy,hz,element,name,basic,s00,s01,s02,s10,s11,s12,s20,s21,s22,score,object,frame\n";
    if (!text || strncmp(text, header, sizeof header - 1) != 0) return -1;
    const char *p = text + sizeof header - 1;
    int n = 0;
    while (*p) {
        if (n == cap) return -1;
        csv_row *r = &rows[n];
        int used = 0;
        int got = sscanf(p,
                         "%u,%u,%u,%lf,%lf,%lf,%lf,%lf,%lf,%u,%63[^,],%63[^,],%d,%d,%d,%d,%d,%d,%d,%d,%d,%f,%63[^,],"
                         "%15[^\n]%n",
                         &r->i, &r->j, &r->k, &r->x, &r->y, &r->z, &r->hx, &r->hy, &r->hz, &r->element, r->name,
                         r->basic, &r->s[0], &r->s[1], &r->s[2], &r->s[3], &r->s[4], &r->s[5], &r->s[6], &r->s[7],
                         &r->s[8], &r->score, r->object, r->frame, &used);
        if (got != 24 || p[used] != '\n') return -1;
        p += used + 1;
        n++;
    }
    return n;
}

typedef struct expect {
    const clvox_palette *palette;
    const clvox_render_map *map; /* NULL: basic names */
    uint32_t X, Y, Z;
    const uint32_t *element;
    const uint16_t *score;
    double origin[3], h[3];
    const float *score_f; /* instead of score (HALF bits): the reader's floats */
} expect;

/* Every row against the volume: rows in z, y, x order, exactly the non-empty voxels. */
static void check_rows(const char *what, const csv_row *rows, int n, const expect *e)
{
    int r = 0, bad = 0;
    for (uint32_t k = 0; k < e->Z; k++)
        for (uint32_t j = 0; j < e->Y; j++)
            for (uint32_t i = 0; i < e->X; i++) {
                size_t at = ((size_t)k * e->Y + j) * e->X + i;
                uint32_t el = e->element[at];
                if (el == 0) continue;
                if (r >= n) {
                    bad++;
                    continue;
                }
                const csv_row *row = &rows[r++];
                clvox_palette_element_info info = CLVOX_PALETTE_ELEMENT_INFO_INIT, basic = CLVOX_PALETTE_ELEMENT_INFO_INIT;
                clvox_palette_element_info_get(g_ctx, e->palette, el, &info);
                clvox_palette_element_info_get(g_ctx, e->palette, info.basic, &basic);
                float score = e->score_f ? e->score_f[at] : (float)exrgen_half_value(e->score[at]);
                int ok = row->i == i && row->j == j && row->k == k && row->element == el &&
                         row->x == e->origin[0] + (i + 0.5) * e->h[0] && row->y == e->origin[1] + (j + 0.5) * e->h[1] &&
                         row->z == e->origin[2] + (k + 0.5) * e->h[2] && row->hx == e->h[0] && row->hy == e->h[1] &&
                         row->hz == e->h[2] && strcmp(row->name, info.name) == 0 &&
                         strcmp(row->basic, basic.name) == 0 && row->score == score;
                for (int q = 0; q < 9; q++) ok &= row->s[q] == info.matrix[q / 3][q % 3];
                const char *want_obj = basic.name, *want_frame = "basic";
                if (e->map) {
                    clvox_render_frame f = CLVOX_RENDER_FRAME_BASIC;
                    want_obj = clvox_render_map_object_name(e->map, clvox_render_map_choose(e->map, el, score, &f));
                    if (f == CLVOX_RENDER_FRAME_ELEMENT) want_frame = "element";
                }
                ok &= want_obj && strcmp(row->object, want_obj) == 0 && strcmp(row->frame, want_frame) == 0;
                if (!ok && bad++ < 5)
                    fprintf(stderr, "%s: row %d (%u,%u,%u) %s %s %s %s differs from voxel (%u,%u,%u) element %u\n",
                            what, r, row->i, row->j, row->k, row->name, row->basic, row->object, row->frame, i, j, k,
                            el);
            }
    CHECK_MSG(bad == 0 && r == n, "%s: %d bad rows, %d rows for %d non-empty voxels", what, bad, n, r);
}

static csv_row g_rows[4096];

/* Runs instances; on success checks the rows and the summary line. */
static void run_ok(const char *what, const char *const *argv, const char *csv, const expect *e, int rows_expected)
{
    spawn_result r;
    spawn_run(&r, argv, 60);
    CHECK_MSG(r.code == 0, "%s: exit %d: %s", what, r.code, r.err);
    CHECK_MSG(r.err[0] == '\0', "%s: stderr: %s", what, r.err);
    char want[64];
    snprintf(want, sizeof want, ": %d rows (", rows_expected);
    CHECK_MSG(count_lines(r.out) == 1 && strncmp(r.out, "wrote ", 6) == 0 && strstr(r.out, want), "%s: stdout: %s",
              what, r.out);
    char *text = read_text(csv);
    int n = parse_csv(text, g_rows, (int)(sizeof g_rows / sizeof g_rows[0]));
    CHECK_MSG(n == rows_expected, "%s: %d rows parsed, %d expected", what, n, rows_expected);
    if (n >= 0) check_rows(what, g_rows, n, e);
    free(text);
    spawn_free(&r);
}

/* Runs a command that must fail with `code` and one error line holding `needle`, leaving g_out empty. */
static void run_fail(const char *what, int code, const char *needle, const char *const *argv)
{
    spawn_result r;
    spawn_run(&r, argv, 60);
    CHECK_MSG(r.code == code, "%s: exit %d, expected %d: %s", what, r.code, code, r.err);
    CHECK_MSG(count_lines(r.err) == 1 && strncmp(r.err, "clvox: error: ", 14) == 0, "%s: stderr: %s", what, r.err);
    if (needle) CHECK_MSG(strstr(r.err, needle) != NULL, "%s: stderr lacks '%s': %s", what, needle, r.err);
    CHECK_MSG(r.out[0] == '\0', "%s: stdout: %s", what, r.out);
    CHECK_MSG(dir_is_empty(g_out), "%s: a file was left behind", what);
    spawn_free(&r);
}

static void test_cli_handmade(void)
{
    clvox_palette *p = builtin("paper46");
    /* 4 x 3 x 2: every kind of element, empty voxels between them */
    enum { X = 4, Y = 3, Z = 2, N = X * Y * Z };
    uint32_t element[N] = {0};
    uint16_t score[N] = {0};
    const char *names[] = {"full", "wedge", "wedge_s3", "wedge_s9", "roof_s26", "column_s13", "corner_s7", "corner"};
    const uint16_t scores[] = {H_ONE, H_075, H_HALF, H_060, H_QUARTER, H_0, H_ONE, H_075};
    const size_t at[] = {0, 3, 5, 6, 11, 12, 18, 23};
    for (size_t q = 0; q < 8; q++) {
        element[at[q]] = index_of(p, names[q]);
        score[at[q]] = scores[q];
    }
    score[1] = H_HALF; /* a score on an empty voxel: no row */
    char vol[PATH_MAX], csv[PATH_MAX], map[PATH_MAX];
    path_join(vol, sizeof vol, g_dir, "hand.exr");
    path_join(csv, sizeof csv, g_dir, "hand.csv");
    path_join(map, sizeof map, g_dir, "hand.render");
    CHECK(make_volume(vol, X, Y, Z, element, score));
    expect e = {p, NULL, X, Y, Z, element, score, {EXRGEN_ORIGIN_X, EXRGEN_ORIGIN_Y, EXRGEN_ORIGIN_Z},
                {EXRGEN_H_X, EXRGEN_H_Y, EXRGEN_H_Z}, NULL};
    run_ok("no map", ARGS("instances", vol, "--palette", "paper46", "-o", csv), csv, &e, 8);
    /* the symmetry images really carry their own matrices (not the identity) */
    int mirrors = 0;
    for (int r = 0; r < 8; r++) {
        const int *s = g_rows[r].s;
        int det = s[0] * (s[4] * s[8] - s[5] * s[7]) - s[1] * (s[3] * s[8] - s[5] * s[6]) +
                  s[2] * (s[3] * s[7] - s[4] * s[6]);
        mirrors += det == -1;
    }
    CHECK_MSG(mirrors >= 2, "only %d rows with a mirror (det S = -1)", mirrors);

    /* a map: thresholds and frames */
    CHECK(write_text(map, "basic wedge\n object good 0.75\n object fair 0.5\n object poor 0\n"
                          "element corner_s7\n object exact 0\n"));
    clvox_render_map *m = NULL;
    CHECK_OK(g_ctx, clvox_render_map_load(g_ctx, map, p, &m));
    e.map = m;
    run_ok("map", ARGS("instances", vol, "--palette", "paper46", "--render-map", map, "-o", csv), csv, &e, 8);
    int frames_element = 0;
    for (int r = 0; r < 8; r++) frames_element += strcmp(g_rows[r].frame, "element") == 0;
    CHECK(frames_element == 1);
    /* the summary counts rows per object */
    spawn_result r;
    spawn_run(&r, ARGS("instances", vol, "--palette", "paper46", "--render-map", map, "-o", csv), 60);
    CHECK_MSG(strstr(r.out, "objects: good 1, fair 2, exact 1, full 1, roof 1, column 1, corner 1\n"),
              "%s", r.out);
    spawn_free(&r);
    clvox_render_map_destroy(m);
    e.map = NULL;
    /* the shipped map */
    m = NULL;
    CHECK_OK(g_ctx, clvox_render_map_load(g_ctx, "palettes/paper46.render", p, &m));
    e.map = m;
    run_ok("paper46.render", ARGS("instances", vol, "--palette", "paper46", "--render-map", "palettes/paper46.render",
                                  "-o", csv),
           csv, &e, 8);
    clvox_render_map_destroy(m);
    e.map = NULL;
    /* an existing regular file is replaced */
    CHECK(write_text(csv, "old"));
    run_ok("replace", ARGS("instances", "--palette=paper46", vol, "--output", csv), csv, &e, 8);

    /* every voxel empty: the header alone */
    uint32_t none[N] = {0};
    char empty_vol[PATH_MAX];
    path_join(empty_vol, sizeof empty_vol, g_dir, "empty.exr");
    CHECK(make_volume(empty_vol, X, Y, Z, none, score));
    expect ee = e;
    ee.element = none;
    run_ok("empty volume", ARGS("instances", empty_vol, "--palette", "paper46", "-o", csv), csv, &ee, 0);

    /* ---- errors: one line, the documented exit code, nothing left in g_out ---- */
    char out[PATH_MAX], bad[PATH_MAX];
    path_join(out, sizeof out, g_out, "x.csv");
    path_join(bad, sizeof bad, g_dir, "bad.render");
    CHECK(write_text(bad, "element full\n object a 0.5\n object b 0.7\n"));
    char want[PATH_MAX + 128];
    snprintf(want, sizeof want, "%s:3: threshold 0.7 is not below the previous one", bad);
    run_fail("bad map", 4, want, ARGS("instances", vol, "--palette", "paper46", "--render-map", bad, "-o", out));
    run_fail("missing map", 4, "cannot open render map",
             ARGS("instances", vol, "--palette", "paper46", "--render-map", "no/such.render", "-o", out));
    run_fail("map for another palette", 4, "palettes/blocks.render:19: no element 'slab_bottom'",
             ARGS("instances", vol, "--palette", "paper46", "--render-map", "palettes/blocks.render", "-o", out));
    /* a value that is no element of the palette (paper46: 0..45) */
    uint32_t big[N];
    memcpy(big, element, sizeof big);
    big[13] = 46;
    char big_vol[PATH_MAX];
    path_join(big_vol, sizeof big_vol, g_dir, "big.exr");
    CHECK(make_volume(big_vol, X, Y, Z, big, score));
    run_fail("element past the palette", 4, "voxel (1,0,1) holds element 46, not an element of palette 'paper46' (0 to 45)",
             ARGS("instances", big_vol, "--palette", "paper46", "-o", out));
    /* ... but it is one of paper78's */
    ee = e;
    ee.element = big;
    clvox_palette *p78 = builtin("paper78");
    ee.palette = p78;
    run_ok("paper78", ARGS("instances", big_vol, "--palette", "paper78", "-o", csv), csv, &ee, 9);
    clvox_palette_destroy(p78);
    /* a score outside [0, 1] */
    uint16_t over[N];
    memcpy(over, score, sizeof over);
    over[23] = H_1_5;
    char over_vol[PATH_MAX];
    path_join(over_vol, sizeof over_vol, g_dir, "over.exr");
    CHECK(make_volume(over_vol, X, Y, Z, element, over));
    run_fail("score above 1", 4, "voxel (3,2,1) has score 1.5, outside [0, 1]",
             ARGS("instances", over_vol, "--palette", "paper46", "-o", out));
    over[23] = 0x7E00; /* NaN */
    CHECK(make_volume(over_vol, X, Y, Z, element, over));
    run_fail("score NaN", 4, "voxel (3,2,1) has score nan, outside [0, 1]",
             ARGS("instances", over_vol, "--palette", "paper46", "-o", out));
    /* an element channel that is not integral */
    float frac[N];
    for (size_t q = 0; q < N; q++) frac[q] = (float)element[q];
    frac[5] = 2.5f;
    exrgen_channel ch[2] = {{"element", EXR_PIXEL_FLOAT, frac}, {"score", EXR_PIXEL_HALF, score}};
    char frac_vol[PATH_MAX];
    path_join(frac_vol, sizeof frac_vol, g_dir, "frac.exr");
    CHECK(exrgen_write(frac_vol, X, Y, Z, ch, 2, 0, 0, EXR_COMPRESSION_NONE, 1));
    run_fail("fractional element", 4, "voxel (1,1,0) holds element 2.5",
             ARGS("instances", frac_vol, "--palette", "paper46", "-o", out));
    /* missing channels */
    char vol_noscore[PATH_MAX], vol_noelem[PATH_MAX];
    path_join(vol_noscore, sizeof vol_noscore, g_dir, "noscore.exr");
    path_join(vol_noelem, sizeof vol_noelem, g_dir, "noelem.exr");
    CHECK(make_volume(vol_noscore, X, Y, Z, element, NULL));
    CHECK(make_volume(vol_noelem, X, Y, Z, NULL, score));
    run_fail("no score channel", 4, "has no score channel (has: element)",
             ARGS("instances", vol_noscore, "--palette", "paper46", "-o", out));
    run_fail("no element channel", 4, "has no element channel (has: score): not a palette volume",
             ARGS("instances", vol_noelem, "--palette", "paper46", "-o", out));
    run_fail("missing volume", 4, "no/such.exr", ARGS("instances", "no/such.exr", "--palette", "paper46", "-o", out));
    char text_file[PATH_MAX];
    path_join(text_file, sizeof text_file, g_dir, "not.exr");
    CHECK(write_text(text_file, "not an EXR file\n"));
    run_fail("not an EXR file", 4, NULL, ARGS("instances", text_file, "--palette", "paper46", "-o", out));
    /* palettes */
    run_fail("unknown palette", 2, "--palette 'nope'", ARGS("instances", vol, "--palette", "nope", "-o", out));
    char bad_pal[PATH_MAX];
    path_join(bad_pal, sizeof bad_pal, g_dir, "bad_palette.txt");
    CHECK(write_text(bad_pal, "element x\n cell\n 1 0 0\nend\n"));
    snprintf(want, sizeof want, "%s:3:", bad_pal);
    run_fail("bad palette file", 4, want, ARGS("instances", vol, "--palette", bad_pal, "-o", out));
    /* a FIFO or a directory as --palette or --render-map (issue 32): refused at
     * once with the reason (before: a FIFO blocked in open until the 60 s
     * limit; a directory said "cannot read palette 'd.txt'" and no why) */
    char fifo[PATH_MAX], dir[PATH_MAX];
    path_join(fifo, sizeof fifo, g_dir, "fifo.txt");
    path_join(dir, sizeof dir, g_dir, "dir.txt");
    unlink(fifo);
    rmdir(dir);
    CHECK(mkfifo(fifo, 0666) == 0 && mkdir(dir, 0777) == 0);
    run_fail("FIFO as --palette", 4, "not a regular file", ARGS("instances", vol, "--palette", fifo, "-o", out));
    run_fail("FIFO as --render-map", 4, "not a regular file",
             ARGS("instances", vol, "--palette", "paper46", "--render-map", fifo, "-o", out));
    run_fail("directory as --palette", 4, strerror(EISDIR), ARGS("instances", vol, "--palette", dir, "-o", out));
    run_fail("directory as --render-map", 4, strerror(EISDIR),
             ARGS("instances", vol, "--palette", "paper46", "--render-map", dir, "-o", out));
    unlink(fifo);
    rmdir(dir);
    /* outputs */
    run_fail("missing -o", 2, "missing -o OUT.csv", ARGS("instances", vol, "--palette", "paper46"));
    run_fail("missing volume argument", 2, "missing VOLUME.exr", ARGS("instances", "-o", out));
    run_fail("two volumes", 2, "more than one volume", ARGS("instances", vol, vol, "-o", out));
    run_fail("unknown option", 2, "unknown option '--frobnicate'", ARGS("instances", vol, "--frobnicate", "-o", out));
    run_fail("-o without a value", 2, "-o needs a file name", ARGS("instances", vol, "-o"));
    run_fail("output is the input", 2, "is the input volume", ARGS("instances", vol, "--palette", "paper46", "-o", vol));
    run_fail("output is the map", 2, "is the render map",
             ARGS("instances", vol, "--palette", "paper46", "--render-map", map, "-o", map));
    run_fail("output is a directory", 5, NULL, ARGS("instances", vol, "--palette", "paper46", "-o", g_out));
    char missing_dir[PATH_MAX];
    path_join(missing_dir, sizeof missing_dir, g_out, "no/x.csv");
    run_fail("output directory missing", 5, NULL, ARGS("instances", vol, "--palette", "paper46", "-o", missing_dir));
    char link_path[PATH_MAX];
    path_join(link_path, sizeof link_path, g_dir, "link.csv");
    unlink(link_path);
    CHECK(symlink("hand.csv", link_path) == 0);
    spawn_result r2;
    spawn_run(&r2, ARGS("instances", vol, "--palette", "paper46", "-o", link_path), 60);
    CHECK_MSG(r2.code == 5 && strstr(r2.err, "symbolic link"), "symlink output: exit %d: %s", r2.code, r2.err);
    struct stat sb;
    CHECK(lstat(link_path, &sb) == 0 && S_ISLNK(sb.st_mode));
    spawn_free(&r2);
    unlink(link_path);
    /* the help */
    spawn_run(&r2, ARGS("instances", "--help"), 60);
    CHECK(r2.code == 0 && strstr(r2.out, "Usage: clvox instances VOLUME.exr -o OUT.csv"));
    spawn_free(&r2);
    spawn_run(&r2, ARGS("--help"), 60);
    CHECK(r2.code == 0 && strstr(r2.out, "clvox instances VOLUME.exr -o OUT.csv"));
    spawn_free(&r2);
    clvox_palette_destroy(p);
}

/* Many slices, a file palette, rows streamed: every non-empty voxel once. */
static void test_cli_slices(void)
{
    clvox_palette *blocks = NULL;
    CHECK_OK(g_ctx, clvox_palette_load(g_ctx, "palettes/blocks.txt", &blocks));
    if (!blocks) return;
    enum { X = 7, Y = 5, Z = 40, N = X * Y * Z };
    static uint32_t element[N];
    static uint16_t score[N];
    static const uint16_t levels[] = {H_0, H_QUARTER, H_HALF, H_060, H_075, H_ONE};
    uint32_t state = 12345, nonempty = 0;
    for (size_t q = 0; q < N; q++) {
        state = state * 1664525u + 1013904223u;
        element[q] = (state >> 8) % 3 == 0 ? 0 : 1 + (state >> 12) % 11; /* blocks: 0..11 */
        score[q] = levels[(state >> 20) % 6];
        nonempty += element[q] != 0;
    }
    char vol[PATH_MAX], csv[PATH_MAX];
    path_join(vol, sizeof vol, g_dir, "slices.exr");
    path_join(csv, sizeof csv, g_dir, "slices.csv");
    CHECK(make_volume(vol, X, Y, Z, element, score));
    clvox_render_map *m = NULL;
    CHECK_OK(g_ctx, clvox_render_map_load(g_ctx, "palettes/blocks.render", blocks, &m));
    expect e = {blocks, m, X, Y, Z, element, score, {EXRGEN_ORIGIN_X, EXRGEN_ORIGIN_Y, EXRGEN_ORIGIN_Z},
                {EXRGEN_H_X, EXRGEN_H_Y, EXRGEN_H_Z}, NULL};
    CHECK(nonempty < sizeof g_rows / sizeof g_rows[0]);
    run_ok("40 slices, blocks.render",
           ARGS("instances", vol, "--palette", "palettes/blocks.txt", "--render-map", "palettes/blocks.render", "-o",
                csv),
           csv, &e, (int)nonempty);
    clvox_render_map_destroy(m);
    clvox_palette_destroy(blocks);
}

/* ---- end to end: clvox --palette, then instances ------------------------------------- */

typedef struct dense {
    uint32_t X, Y;
    uint32_t *element;
    float *score;
    int which; /* 0 element, 1 score */
} dense;

static int on_dense(void *user, uint32_t z, const float *v)
{
    dense *d = user;
    size_t n = (size_t)d->X * d->Y;
    for (size_t q = 0; q < n; q++) {
        if (d->which == 0) d->element[(size_t)z * n + q] = (uint32_t)v[q];
        else d->score[(size_t)z * n + q] = v[q];
    }
    return 0;
}

static void end_to_end(const char *what, const char *palette_arg, const char *map_path, const char *stem)
{
    char vol[PATH_MAX], csv[PATH_MAX], name[64];
    snprintf(name, sizeof name, "%s.exr", stem);
    path_join(vol, sizeof vol, g_dir, name);
    snprintf(name, sizeof name, "%s.csv", stem);
    path_join(csv, sizeof csv, g_dir, name);
    spawn_result r;
    spawn_run(&r, ARGS("tests/data/default.obj", "-r", "14", "--palette", palette_arg, "-q", "-o", vol), 120);
    CHECK_MSG(r.code == 0, "%s: voxelize: exit %d: %s", what, r.code, r.err);
    spawn_free(&r);
    if (r.code != 0) return;
    /* what the volume holds, read back by the library */
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    dense d = {0, 0, NULL, NULL, 0};
    clvox_palette *p = NULL;
    CHECK_OK(g_ctx, clvox_volume_palette(g_ctx, vol, &p));
    clvox_status st = clvox_volume_read(g_ctx, vol, &info, NULL, 0);
    CHECK_OK(g_ctx, st);
    if (!p || st != CLVOX_OK) {
        clvox_palette_destroy(p);
        return;
    }
    size_t n = (size_t)info.dims[0] * info.dims[1] * info.dims[2];
    d.X = info.dims[0];
    d.Y = info.dims[1];
    d.element = calloc(n, sizeof *d.element);
    d.score = calloc(n, sizeof *d.score);
    if (!d.element || !d.score) abort();
    CHECK_OK(g_ctx, clvox_volume_read_slices(g_ctx, vol, "element", NULL, on_dense, &d));
    d.which = 1;
    CHECK_OK(g_ctx, clvox_volume_read_slices(g_ctx, vol, "score", NULL, on_dense, &d));
    int nonempty = 0, images = 0;
    for (size_t q = 0; q < n; q++)
        if (d.element[q]) {
            nonempty++;
            clvox_palette_element_info ei = CLVOX_PALETTE_ELEMENT_INFO_INIT;
            if (clvox_palette_element_info_get(g_ctx, p, d.element[q], &ei) == CLVOX_OK) images += ei.symmetry != 0;
        }
    CHECK_MSG(nonempty > 0 && nonempty == (int)info.filled_voxels && (size_t)nonempty < n,
              "%s: %d non-empty voxels, %llu filled, %zu in all", what, nonempty,
              (unsigned long long)info.filled_voxels, n);
    clvox_render_map *m = NULL;
    if (map_path) CHECK_OK(g_ctx, clvox_render_map_load(g_ctx, map_path, p, &m));
    expect e = {p, m, info.dims[0], info.dims[1], info.dims[2], d.element, NULL,
                {info.origin[0], info.origin[1], info.origin[2]},
                {info.voxel_size[0], info.voxel_size[1], info.voxel_size[2]}, d.score};
    CHECK(nonempty < (int)(sizeof g_rows / sizeof g_rows[0]));
    /* the palette comes from the header */
    if (map_path) run_ok(what, ARGS("instances", vol, "--render-map", map_path, "-o", csv), csv, &e, nonempty);
    else run_ok(what, ARGS("instances", vol, "-o", csv), csv, &e, nonempty);
    if (strcmp(palette_arg, "paper46") == 0)
        CHECK_MSG(images > 0, "%s: no voxel got a symmetry image (the S check would be trivial)", what);
    /* ... and a palette given that is not the header's is refused */
    char out[PATH_MAX];
    path_join(out, sizeof out, g_out, "x.csv");
    run_fail("another palette than the header's", 4, "was scored with palette",
             ARGS("instances", vol, "--palette", strcmp(palette_arg, "paper78") ? "paper78" : "paper46", "-o", out));
    /* the same one is accepted */
    run_ok(what, ARGS("instances", vol, "--palette", palette_arg, "-o", csv), csv, &(expect){p, NULL, e.X, e.Y, e.Z,
           d.element, NULL, {e.origin[0], e.origin[1], e.origin[2]}, {e.h[0], e.h[1], e.h[2]}, d.score}, nonempty);
    clvox_render_map_destroy(m);
    clvox_palette_destroy(p);
    free(d.element);
    free(d.score);
}

static void test_end_to_end(void)
{
    end_to_end("paper46 end to end", "paper46", "palettes/paper46.render", "e2e46");
    end_to_end("blocks.txt end to end (the palette text in the header)", "palettes/blocks.txt",
               "palettes/blocks.render", "e2eblocks");
    end_to_end("paper78, no map", "paper78", NULL, "e2e78");
    /* a volume without a palette: instances needs one */
    char vol[PATH_MAX], out[PATH_MAX];
    path_join(vol, sizeof vol, g_dir, "binary.exr");
    path_join(out, sizeof out, g_out, "x.csv");
    spawn_result r;
    spawn_run(&r, ARGS("tests/data/default.obj", "-r", "8", "-q", "-o", vol), 120);
    CHECK_MSG(r.code == 0, "binary voxelize: exit %d: %s", r.code, r.err);
    spawn_free(&r);
    run_fail("a binary volume", 4, NULL, ARGS("instances", vol, "-o", out));
    run_fail("a binary volume with --palette", 4, "has no element channel",
             ARGS("instances", vol, "--palette", "paper46", "-o", out));
}

int main(void)
{
    const char *bin = getenv("CLVOX_BIN");
    if (!bin || !*bin) bin = "build/release/clvox";
    if (!realpath(bin, g_bin)) {
        fprintf(stderr, "cannot find the clvox binary '%s' (set CLVOX_BIN)\n", bin);
        printf("0 passed, 1 failed\n");
        return 1;
    }
    path_join(g_dir, sizeof g_dir, test_tmpdir(), "instances");
    mkdir(g_dir, 0777);
    path_join(g_out, sizeof g_out, g_dir, "out");
    mkdir(g_out, 0777);
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    if (clvox_context_create(&o, &g_ctx) != CLVOX_OK) {
        printf("0 passed, 1 failed\n");
        return 1;
    }
    test_thresholds();
    test_precedence();
    test_examples();
    test_map_errors();
    test_cli_handmade();
    test_cli_slices();
    test_end_to_end();
    clvox_context_destroy(g_ctx);
    return test_report();
}
