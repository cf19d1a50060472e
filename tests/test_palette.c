/* SPDX-License-Identifier: Apache-2.0 */
/* Palettes (issue 8, data): the built-in counts 2, 10, 46, 78; index 0
 * empty and 1 full everywhere; all elements distinct; paper78's complements
 * exact; paper46 closed under the 48 cube symmetries and each element the
 * image of its basic element under its recorded symmetry; exact volumes;
 * planar10 as documented; the example palette file; symmetry expansion of a
 * file; every kind of malformed line with its line number; bad arguments.
 * Host only: no OpenCL device. Membership is compared on the dense offset
 * grid ((i,j,k) + 1/2 + (1,3,9)/64) / 32, on which (docs/design.md
 * "Palettes") no built-in plane passes through a point and the float test is
 * exact, so "same samples" is "same set up to its boundary". */
#include "test.h"

#include <errno.h>
#include <math.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define N 32u
#define NPTS (N * N * N)

static clvox_context *ctx;

static float gp(uint32_t i, int axis)
{
    static const int off[3] = {33, 35, 41};
    return (float)((double)(i * 64u + (uint32_t)off[axis]) / (64.0 * N));
}

/* Membership of element e on the grid, as 0/1 bytes. */
static void mask_of(const clvox_palette *p, size_t e, unsigned char *m)
{
    size_t b = 0;
    for (uint32_t k = 0; k < N; k++)
        for (uint32_t j = 0; j < N; j++)
            for (uint32_t i = 0; i < N; i++) m[b++] = (unsigned char)clvox_palette_contains(p, e, gp(i, 0), gp(j, 1), gp(k, 2));
}

/* Mask of the image of element e under symmetry matrix S: q is in the image
 * when p = S^T (q - 1/2) + 1/2 is in e (exact in float: 1 - q or q). */
static void image_mask(const clvox_palette *p, size_t e, const int32_t S[3][3], unsigned char *m)
{
    size_t b = 0;
    for (uint32_t k = 0; k < N; k++)
        for (uint32_t j = 0; j < N; j++)
            for (uint32_t i = 0; i < N; i++) {
                float q[3] = {gp(i, 0), gp(j, 1), gp(k, 2)}, pp[3] = {0, 0, 0};
                for (int r = 0; r < 3; r++)
                    for (int c = 0; c < 3; c++)
                        if (S[r][c]) pp[c] = S[r][c] > 0 ? q[r] : 1.0f - q[r];
                m[b++] = (unsigned char)clvox_palette_contains(p, e, pp[0], pp[1], pp[2]);
            }
}

static clvox_palette *builtin(const char *name)
{
    clvox_palette *p = NULL;
    CHECK_OK(ctx, clvox_palette_builtin(ctx, name, &p));
    return p;
}

/* All 48 signed permutation matrices, in any order. */
static int all_symmetries(int32_t S[48][3][3])
{
    static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    int n = 0;
    for (int pi = 0; pi < 6; pi++)
        for (int m = 0; m < 8; m++, n++) {
            memset(S[n], 0, sizeof S[n]);
            for (int r = 0; r < 3; r++) S[n][r][perms[pi][r]] = (m >> r) & 1 ? -1 : 1;
        }
    return n;
}

static void test_counts_and_trivial(void)
{
    static const char *const names[] = {"binary", "planar10", "paper46", "paper78"};
    static const size_t counts[] = {2, 10, 46, 78};
    unsigned char *m = malloc(NPTS);
    for (size_t i = 0; i < 4; i++) {
        CHECK(clvox_palette_builtin_name(i) && strcmp(clvox_palette_builtin_name(i), names[i]) == 0);
        clvox_palette *p = builtin(names[i]);
        if (!p) continue;
        CHECK_MSG(clvox_palette_count(p) == counts[i], "%s: %zu elements", names[i], clvox_palette_count(p));
        CHECK(strcmp(clvox_palette_name(p), names[i]) == 0);
        size_t empty = 0, full = 0;
        mask_of(p, 0, m);
        for (size_t b = 0; b < NPTS; b++) empty += m[b];
        mask_of(p, 1, m);
        for (size_t b = 0; b < NPTS; b++) full += m[b];
        CHECK_MSG(empty == 0 && full == NPTS, "%s: element 0 has %zu points, 1 has %zu", names[i], empty, full);
        clvox_palette_element_info e0 = CLVOX_PALETTE_ELEMENT_INFO_INIT, e1 = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, 0, &e0));
        CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, 1, &e1));
        CHECK(strcmp(e0.name, "empty") == 0 && e0.volume == 0.0 && e0.volume_exact);
        CHECK(strcmp(e1.name, "full") == 0 && e1.volume == 1.0 && e1.volume_exact);
        clvox_palette_destroy(p);
    }
    CHECK(clvox_palette_builtin_name(4) == NULL);
    free(m);
}

/* Every pair of elements differs on the grid; volumes match the samples. */
static void check_distinct(const clvox_palette *p, const char *what)
{
    size_t n = clvox_palette_count(p);
    unsigned char *m = malloc(n * NPTS);
    for (size_t e = 0; e < n; e++) mask_of(p, e, m + e * NPTS);
    int same = 0;
    for (size_t a = 0; a < n; a++)
        for (size_t b = a + 1; b < n; b++)
            if (memcmp(m + a * NPTS, m + b * NPTS, NPTS) == 0) {
                same++;
                fprintf(stderr, "%s: elements %zu and %zu are equal\n", what, a, b);
            }
    CHECK_MSG(same == 0, "%s: %d equal pairs", what, same);
    int names_clash = 0;
    for (size_t a = 0; a < n; a++) {
        clvox_palette_element_info ia = CLVOX_PALETTE_ELEMENT_INFO_INIT, ib = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        clvox_palette_element_info_get(ctx, p, a, &ia);
        size_t in = 0;
        for (size_t b = 0; b < NPTS; b++) in += m[a * NPTS + b];
        CHECK_MSG(fabs(ia.volume - (double)in / NPTS) < 0.02, "%s %s: volume %g, samples %g", what, ia.name,
                  ia.volume, (double)in / NPTS);
        for (size_t b = a + 1; b < n; b++) {
            clvox_palette_element_info_get(ctx, p, b, &ib);
            names_clash += strcmp(ia.name, ib.name) == 0;
        }
    }
    CHECK_MSG(names_clash == 0, "%s: %d repeated names", what, names_clash);
    free(m);
}

static void test_distinct(void)
{
    static const char *const names[] = {"binary", "planar10", "paper46", "paper78"};
    for (size_t i = 0; i < 4; i++) {
        clvox_palette *p = builtin(names[i]);
        if (p) check_distinct(p, names[i]);
        clvox_palette_destroy(p);
    }
}

static void test_complements(void)
{
    clvox_palette *p46 = builtin("paper46"), *p78 = builtin("paper78");
    if (!p46 || !p78) return;
    unsigned char *a = malloc(NPTS), *b = malloc(NPTS), *c = malloc(NPTS);
    /* the first 46 of paper78 are paper46 */
    for (size_t e = 0; e < 46; e++) {
        mask_of(p46, e, a);
        mask_of(p78, e, b);
        CHECK_MSG(memcmp(a, b, NPTS) == 0, "paper78 element %zu differs from paper46's", e);
    }
    size_t complements = 0;
    for (size_t e = 46; e < 78; e++) {
        clvox_palette_element_info ie = CLVOX_PALETTE_ELEMENT_INFO_INIT, io = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p78, e, &ie));
        CHECK_MSG(ie.complement_of >= 2 && ie.complement_of < 46, "element %zu: complement_of %u", e,
                  ie.complement_of);
        if (ie.complement_of >= 46) continue;
        CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p78, ie.complement_of, &io));
        mask_of(p78, e, a);
        mask_of(p78, ie.complement_of, b);
        size_t wrong = 0;
        for (size_t k = 0; k < NPTS; k++) wrong += a[k] == b[k];
        CHECK_MSG(wrong == 0, "%s is not the complement of %s at %zu points", ie.name, io.name, wrong);
        CHECK_MSG(ie.volume_exact && io.volume_exact && ie.volume + io.volume == 1.0, "%s: volumes %g + %g",
                  ie.name, ie.volume, io.volume);
        complements++;
    }
    CHECK(complements == 32);
    /* every non-trivial element of paper46 has its complement in paper78 */
    for (size_t e = 2; e < 46; e++) {
        mask_of(p46, e, a);
        for (size_t k = 0; k < NPTS; k++) a[k] = !a[k];
        int found = 0;
        for (size_t f = 0; f < 78 && !found; f++) {
            mask_of(p78, f, c);
            found = memcmp(a, c, NPTS) == 0;
        }
        CHECK_MSG(found, "complement of paper46 element %zu missing from paper78", e);
    }
    free(a);
    free(b);
    free(c);
    clvox_palette_destroy(p46);
    clvox_palette_destroy(p78);
}

static void test_symmetry_closure(void)
{
    clvox_palette *p = builtin("paper46");
    if (!p) return;
    int32_t S[48][3][3];
    CHECK(all_symmetries(S) == 48);
    size_t n = clvox_palette_count(p);
    unsigned char *m = malloc(n * NPTS), *img = malloc(NPTS);
    for (size_t e = 0; e < n; e++) mask_of(p, e, m + e * NPTS);
    int missing = 0, wrong_record = 0;
    for (size_t e = 0; e < n; e++) {
        for (int s = 0; s < 48; s++) {
            image_mask(p, e, (const int32_t(*)[3])S[s], img);
            int found = 0;
            for (size_t f = 0; f < n && !found; f++) found = memcmp(img, m + f * NPTS, NPTS) == 0;
            missing += !found;
        }
        /* the recorded basic element and symmetry give back this element */
        clvox_palette_element_info ie = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, e, &ie));
        image_mask(p, ie.basic, (const int32_t(*)[3])ie.matrix, img);
        wrong_record += memcmp(img, m + e * NPTS, NPTS) != 0;
        CHECK(ie.symmetry < 48 && ie.basic <= e);
    }
    CHECK_MSG(missing == 0, "paper46: %d images outside the palette", missing);
    CHECK_MSG(wrong_record == 0, "paper46: %d elements are not S(basic)", wrong_record);
    /* the same for paper78's recorded symmetries */
    clvox_palette *p78 = builtin("paper78");
    if (p78) {
        unsigned char *a = malloc(NPTS);
        int bad = 0;
        for (size_t e = 0; e < 78; e++) {
            clvox_palette_element_info ie = CLVOX_PALETTE_ELEMENT_INFO_INIT;
            clvox_palette_element_info_get(ctx, p78, e, &ie);
            image_mask(p78, ie.basic, (const int32_t(*)[3])ie.matrix, img);
            mask_of(p78, e, a);
            bad += memcmp(img, a, NPTS) != 0;
        }
        CHECK_MSG(bad == 0, "paper78: %d elements are not S(basic)", bad);
        free(a);
    }
    clvox_palette_destroy(p78);
    free(m);
    free(img);
    clvox_palette_destroy(p);
}

static void test_volumes_and_groups(void)
{
    clvox_palette *p = builtin("paper46");
    if (!p) return;
    static const struct { const char *name; size_t first, count; double volume; } groups[] = {
        {"wedge", 2, 12, 0.5}, {"roof", 14, 12, 0.5}, {"column", 26, 12, 0.25}, {"corner", 38, 8, 1.0 / 6.0}};
    for (int g = 0; g < 4; g++) {
        for (size_t e = groups[g].first; e < groups[g].first + groups[g].count; e++) {
            clvox_palette_element_info ie = CLVOX_PALETTE_ELEMENT_INFO_INIT;
            CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, e, &ie));
            CHECK_MSG(ie.volume == groups[g].volume && ie.volume_exact, "%s: volume %.17g", ie.name, ie.volume);
            CHECK_MSG(ie.basic == groups[g].first && strncmp(ie.name, groups[g].name, strlen(groups[g].name)) == 0,
                      "%zu %s: basic %u", e, ie.name, ie.basic);
        }
        clvox_palette_element_info b = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        clvox_palette_element_info_get(ctx, p, groups[g].first, &b);
        CHECK(strcmp(b.name, groups[g].name) == 0 && b.symmetry == 0);
    }
    /* the basic elements as the issue defines them */
    CHECK(clvox_palette_contains(p, 2, 0.4f, 0.55f, 0.9f) && !clvox_palette_contains(p, 2, 0.6f, 0.45f, 0.1f));
    CHECK(clvox_palette_contains(p, 14, 0.5f, 0.1f, 0.99f) && !clvox_palette_contains(p, 14, 0.2f, 0.5f, 0.5f));
    CHECK(clvox_palette_contains(p, 26, 0.49f, 0.49f, 0.9f) && !clvox_palette_contains(p, 26, 0.51f, 0.1f, 0.1f));
    CHECK(clvox_palette_contains(p, 38, 0.3f, 0.3f, 0.3f) && !clvox_palette_contains(p, 38, 0.4f, 0.4f, 0.3f));
    /* closed half-spaces: the wedge's plane belongs to the wedge, not to its complement */
    CHECK(clvox_palette_contains(p, 2, 0.5f, 0.5f, 0.5f));
    clvox_palette *p78 = builtin("paper78");
    if (p78) {
        clvox_palette_element_info ie = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        clvox_palette_element_info_get(ctx, p78, 46, &ie);
        CHECK(strcmp(ie.name, "not_roof") == 0 && ie.complement);
        CHECK(clvox_palette_contains(p78, 14, 0.25f, 0.5f, 0.5f) && !clvox_palette_contains(p78, 46, 0.25f, 0.5f, 0.5f));
    }
    clvox_palette_destroy(p78);
    clvox_palette_destroy(p);
}

static void test_planar10(void)
{
    clvox_palette *p = builtin("planar10");
    if (!p) return;
    static const char *const names[10] = {"empty",     "full",    "half_x_lo", "half_x_hi", "half_y_lo",
                                          "half_y_hi", "diag_00", "diag_10",   "diag_01",   "diag_11"};
    int bad = 0;
    for (size_t e = 0; e < 10; e++) {
        clvox_palette_element_info ie = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, e, &ie));
        CHECK_MSG(strcmp(ie.name, names[e]) == 0, "planar10 %zu: %s", e, ie.name);
        CHECK(ie.volume == (e == 0 ? 0.0 : e == 1 ? 1.0 : 0.5));
        for (uint32_t k = 0; k < N; k++)
            for (uint32_t j = 0; j < N; j++)
                for (uint32_t i = 0; i < N; i++) {
                    float x = gp(i, 0), y = gp(j, 1);
                    int want[10] = {0, 1, x <= 0.5f, x >= 0.5f, y <= 0.5f, y >= 0.5f, x + y <= 1, y <= x, x <= y, x + y >= 1};
                    bad += clvox_palette_contains(p, e, x, y, gp(k, 2)) != want[e];
                }
    }
    CHECK_MSG(bad == 0, "planar10: %d points differ from the documented definitions", bad);
    clvox_palette_destroy(p);
}

static void test_example_file(void)
{
    clvox_palette *p = NULL;
    CHECK_OK(ctx, clvox_palette_load(ctx, "palettes/blocks.txt", &p));
    if (!p) return;
    CHECK(clvox_palette_count(p) == 12);
    CHECK(strcmp(clvox_palette_name(p), "blocks") == 0);
    check_distinct(p, "blocks");
    clvox_palette_element_info ie = CLVOX_PALETTE_ELEMENT_INFO_INIT;
    CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, 2, &ie));
    CHECK(strcmp(ie.name, "slab_bottom") == 0 && ie.volume == 0.5 && !ie.volume_exact);
    CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, 4, &ie));
    CHECK(strcmp(ie.name, "stairs_east") == 0 && ie.volume == 0.75 && ie.cell_count == 2);
    CHECK(clvox_palette_contains(p, 4, 0.9f, 0.5f, 0.9f) && !clvox_palette_contains(p, 4, 0.1f, 0.5f, 0.9f));
    CHECK(clvox_palette_contains(p, 8, 0.9f, 0.5f, 0.1f) && !clvox_palette_contains(p, 8, 0.1f, 0.5f, 0.1f));
    clvox_palette_destroy(p);
}

static clvox_status parse(const char *text, clvox_palette **p)
{
    return clvox_palette_parse(ctx, "t.txt", text, strlen(text), p);
}

static void test_file_features(void)
{
    clvox_palette *p = NULL;
    /* symmetry expansion reproduces paper46's wedge group; complement flag */
    CHECK_OK(ctx, parse("# wedge\nelement w\n cell\n  1 1 0 1  # x+y<=1\n symmetry\nend\n"
                        "element notc\n complement\n cell\n 1 0 0 .5\n 0 1 0 0.5\nend\n", &p));
    if (p) {
        CHECK_MSG(clvox_palette_count(p) == 15, "%zu elements", clvox_palette_count(p));
        clvox_palette_element_info ie = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, 3, &ie));
        CHECK(strncmp(ie.name, "w_s", 3) == 0 && ie.basic == 2 && ie.symmetry > 0);
        CHECK_OK(ctx, clvox_palette_element_info_get(ctx, p, 14, &ie));
        CHECK(strcmp(ie.name, "notc") == 0 && ie.complement && ie.volume == 0.75);
        CHECK(!clvox_palette_contains(p, 14, 0.2f, 0.2f, 0.5f) && clvox_palette_contains(p, 14, 0.7f, 0.2f, 0.5f));
        CHECK(strcmp(clvox_palette_name(p), "t") == 0);
    }
    clvox_palette_destroy(p);
    /* duplicates of empty/full and of earlier elements are dropped; CRLF; an empty file */
    CHECK_OK(ctx, parse("element e\r\nend\r\nelement f\ncell\nend\nelement a\ncell\n1 0 0 0.5\nend\n"
                        "element b\ncell\n2 0 0 1\nend\n", &p));
    CHECK(p && clvox_palette_count(p) == 3);
    clvox_palette_destroy(p);
    CHECK_OK(ctx, parse("", &p));
    CHECK(p && clvox_palette_count(p) == 2);
    clvox_palette_destroy(p);
}

static void expect_bad(const char *text, unsigned line, const char *needle)
{
    clvox_palette *p = (clvox_palette *)&p; /* must be set to NULL */
    clvox_status st = parse(text, &p);
    char want[32];
    snprintf(want, sizeof want, "t.txt:%u: ", line);
    const char *msg = clvox_context_error(ctx);
    CHECK_MSG(st == CLVOX_ERR_PALETTE_FORMAT, "[%s]: %s", text, clvox_status_string(st));
    CHECK_MSG(p == NULL, "[%s]: out not cleared", text);
    CHECK_MSG(strncmp(msg, want, strlen(want)) == 0 && strstr(msg, needle) && !strchr(msg, '\n'),
              "[%s]: message '%s', want '%s...%s'", text, msg, want, needle);
}

static void test_bad_files(void)
{
    expect_bad("bogus\n", 1, "unknown directive");
    expect_bad("\n\n1 0 0 1\n", 3, "outside an element");
    expect_bad("element a\n1 0 0 1\nend\n", 2, "before the element's first 'cell'");
    expect_bad("element a\ncell\n1 0 0\nend\n", 3, "4 numbers");
    expect_bad("element a\ncell\n1 0 0 1 2\nend\n", 3, "4 numbers");
    expect_bad("element a\ncell\n1 0 x 1\nend\n", 3, "not a finite number");
    expect_bad("element a\ncell\n1 0 0 nan\nend\n", 3, "not a finite number");
    expect_bad("element a\ncell\n1 0 0 1e300\nend\n", 3, "not a finite number");
    expect_bad("element a\ncell\n0 0 0 1\nend\n", 3, "a = b = c = 0");
    expect_bad("cell\n", 1, "outside an element");
    expect_bad("# c\ncomplement\n", 2, "outside an element");
    expect_bad("symmetry\n", 1, "outside an element");
    expect_bad("end\n", 1, "outside an element");
    expect_bad("element a\ncell 1\nend\n", 2, "takes no arguments");
    expect_bad("element a\ncomplement\ncomplement\nend\n", 3, "given twice");
    expect_bad("element a\nsymmetry\nsymmetry\nend\n", 3, "given twice");
    expect_bad("element\n", 1, "one name");
    expect_bad("element a b\n", 1, "one name");
    expect_bad("element a/b\n", 1, "bad element name");
    expect_bad("element a\ncell\n1 0 0 0.5\nend\nelement a\n", 5, "already taken");
    expect_bad("element empty\n", 1, "already taken");
    expect_bad("element a\nelement b\n", 2, "has no 'end'");
    expect_bad("\nelement a\ncell\n", 2, "has no 'end'");
    char big[8192];
    size_t n = (size_t)snprintf(big, sizeof big, "element a\ncell\n");
    for (int i = 0; i < 65; i++) n += (size_t)snprintf(big + n, sizeof big - n, "1 0 0 1\n");
    expect_bad(big, 67, "more than 64 half-spaces");
    n = (size_t)snprintf(big, sizeof big, "element a\n");
    for (int i = 0; i < 65; i++) n += (size_t)snprintf(big + n, sizeof big - n, "cell\n");
    expect_bad(big, 66, "more than 64 cells");
    /* NUL inside the text: parse with the full size */
    {
        static const char nul[] = "element a\nend\n\0\n";
        clvox_palette *p = NULL;
        CHECK_STATUS(ctx, clvox_palette_parse(ctx, "t.txt", nul, sizeof nul - 1, &p), CLVOX_ERR_PALETTE_FORMAT);
        CHECK(strncmp(clvox_context_error(ctx), "t.txt:3: NUL", 12) == 0);
    }
    clvox_palette *p = NULL;
    CHECK_STATUS(ctx, clvox_palette_load(ctx, "tests/data/no-such-palette.txt", &p), CLVOX_ERR_IO);
    CHECK(p == NULL && strstr(clvox_context_error(ctx), "no-such-palette.txt"));
    /* not a regular file (issue 32): a FIFO is refused without blocking in
     * open (alarm: before, the load hung), a directory names the reason */
    char path[4096];
    snprintf(path, sizeof path, "%s/palette-fifo.txt", test_tmpdir());
    unlink(path);
    CHECK(mkfifo(path, 0666) == 0);
    alarm(60);
    CHECK_STATUS(ctx, clvox_palette_load(ctx, path, &p), CLVOX_ERR_IO);
    alarm(0);
    CHECK(p == NULL && strstr(clvox_context_error(ctx), "not a regular file") &&
          strstr(clvox_context_error(ctx), "palette-fifo.txt"));
    unlink(path);
    snprintf(path, sizeof path, "%s/palette-dir.txt", test_tmpdir());
    rmdir(path);
    CHECK(mkdir(path, 0777) == 0);
    CHECK_STATUS(ctx, clvox_palette_load(ctx, path, &p), CLVOX_ERR_IO);
    CHECK(p == NULL && strstr(clvox_context_error(ctx), strerror(EISDIR)) &&
          strstr(clvox_context_error(ctx), "palette-dir.txt"));
    rmdir(path);
}

static void test_arguments(void)
{
    clvox_palette *p = NULL;
    CHECK_STATUS(ctx, clvox_palette_builtin(ctx, "paper47", &p), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(p == NULL && strstr(clvox_context_error(ctx), "paper47"));
    CHECK_STATUS(ctx, clvox_palette_builtin(ctx, NULL, &p), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox_palette_builtin(ctx, "binary", NULL), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(ctx, clvox_palette_load(ctx, NULL, &p), CLVOX_ERR_INVALID_ARGUMENT);
    clvox_palette_destroy(NULL);
    CHECK(clvox_palette_count(NULL) == 0);
    p = builtin("binary");
    clvox_palette_element_info ie = CLVOX_PALETTE_ELEMENT_INFO_INIT;
    CHECK_STATUS(ctx, clvox_palette_element_info_get(ctx, p, 2, &ie), CLVOX_ERR_INVALID_ARGUMENT);
    CHECK(clvox_palette_contains(p, 2, 0.5f, 0.5f, 0.5f) == 0);
    CHECK(strcmp(clvox_status_string(CLVOX_ERR_PALETTE_FORMAT), "malformed palette file") == 0);
    clvox_palette_destroy(p);
}

int main(void)
{
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    o.host_only = 1;
    if (clvox_context_create(&o, &ctx) != CLVOX_OK) {
        fprintf(stderr, "FAIL: host context\n");
        return 1;
    }
    test_counts_and_trivial();
    test_distinct();
    test_complements();
    test_symmetry_closure();
    test_volumes_and_groups();
    test_planar10();
    test_example_file();
    test_file_features();
    test_bad_files();
    test_arguments();
    clvox_context_destroy(ctx);
    return test_report();
}
