/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clvox palette list
 * clvox palette show NAME|FILE
 *
 * The palettes of palette voxelization (Cavagnino & Gribaudo): `list` prints
 * the built-in palettes, one line each (name, element count, what it is);
 * `show` prints one palette: a title line, a header line, then one row per
 * element: index, name, volume (fraction of the voxel; "exact" or "sampled"
 * on 64^3 points), cells/planes, complement flag, the basic element it is an
 * image of, and the cube symmetry mapping the basic element onto it, written
 * as the image q of a point p = (x, y, z): e.g. (1-y,x,z) means
 * q = (1 - p_y, p_x, p_z). NAME is a built-in; anything else is read as a
 * palette file (docs/design.md "Palette files"). Needs no OpenCL device.
 */
#include "cli_common.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

static const char *const descriptions[] = {
    "empty, full",
    "2-D: empty, full, 4 half-boxes, 4 diagonal prisms, constant along z (a reconstruction)",
    "empty, full + wedge, roof, column, corner under the 48 cube symmetries (12+12+12+8)",
    "paper46 + the complements not already present (12+12+8)",
};

static void print_palette_help(void)
{
    fputs(
"Usage: clvox palette list\n"
"       clvox palette show NAME|FILE\n"
"\n"
"list: the built-in palettes (name, element count, description).\n"
"show: the elements of a built-in palette NAME or of a palette FILE, one row\n"
"each: index, name, volume (fraction of the voxel, exact or sampled on 64^3\n"
"points), cells and half-spaces, complement, the basic element it is an image\n"
"of and the cube symmetry that maps the basic element onto it, written as the\n"
"image of a point (x,y,z) of the unit voxel, e.g. (1-y,x,z).\n"
"Index 0 is always the empty element and index 1 the full one.\n"
"Palette files: docs/design.md \"Palette files\"; example: palettes/blocks.txt.\n"
"Exit codes: 0 success, 2 usage error or unknown palette name, 4 bad or\n"
"unreadable palette file.\n", stdout);
}

/* "(1-y,x,z)": the image q of p = (x, y, z) under matrix m. */
static void format_symmetry(int32_t m[3][3], char *buf, size_t size)
{
    static const char axis[3] = {'x', 'y', 'z'};
    size_t n = 0;
    n += (size_t)snprintf(buf + n, size - n, "(");
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            if (m[i][j] && n < size)
                n += (size_t)snprintf(buf + n, size - n, "%s%c%s", m[i][j] < 0 ? "1-" : "", axis[j], i < 2 ? "," : ")");
}

static int cmd_list(void)
{
    printf("%-10s %8s  %s\n", "name", "elements", "description");
    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_status st = clvox_context_create(&co, &ctx);
    for (size_t i = 0; st == CLVOX_OK && clvox_palette_builtin_name(i); i++) {
        clvox_palette *p = NULL;
        st = clvox_palette_builtin(ctx, clvox_palette_builtin_name(i), &p);
        if (st == CLVOX_OK)
            printf("%-10s %8zu  %s\n", clvox_palette_name(p), clvox_palette_count(p),
                   i < sizeof descriptions / sizeof descriptions[0] ? descriptions[i] : "");
        clvox_palette_destroy(p);
    }
    int rc = st == CLVOX_OK ? EXIT_OK : fail_status(ctx, st, ROLE_OTHER);
    clvox_context_destroy(ctx);
    return rc;
}

static int is_builtin(const char *name)
{
    for (size_t i = 0; clvox_palette_builtin_name(i); i++)
        if (strcmp(name, clvox_palette_builtin_name(i)) == 0) return 1;
    return 0;
}

static int cmd_show(const char *what)
{
    struct stat sb;
    if (!is_builtin(what) && stat(what, &sb) != 0)
        return usage_error("palette: unknown palette '%s': not a built-in (binary, planar10, paper46, paper78) and "
                           "no such file",
                           what);
    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_palette *p = NULL;
    clvox_status st = clvox_context_create(&co, &ctx);
    if (st == CLVOX_OK)
        st = is_builtin(what) ? clvox_palette_builtin(ctx, what, &p) : clvox_palette_load(ctx, what, &p);
    if (st != CLVOX_OK) {
        int rc = fail_status(ctx, st, ROLE_INPUT);
        clvox_context_destroy(ctx);
        return rc;
    }
    size_t n = clvox_palette_count(p);
    printf("palette %s: %zu elements\n", clvox_palette_name(p), n);
    printf("%5s  %-20s %9s %-7s %5s %6s %-5s  %-20s %s\n", "index", "name", "volume", "", "cells", "planes", "compl",
           "basic", "symmetry");
    for (size_t i = 0; i < n && st == CLVOX_OK; i++) {
        clvox_palette_element_info e = CLVOX_PALETTE_ELEMENT_INFO_INIT, b = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        st = clvox_palette_element_info_get(ctx, p, i, &e);
        if (st == CLVOX_OK) st = clvox_palette_element_info_get(ctx, p, e.basic, &b);
        if (st != CLVOX_OK) break;
        char sym[64];
        format_symmetry(e.matrix, sym, sizeof sym);
        printf("%5zu  %-20s %9.6f %-7s %5u %6u %-5s  %-20s s%-2u %s\n", i, e.name, e.volume,
               e.volume_exact ? "exact" : "sampled", e.cell_count, e.plane_count, e.complement ? "yes" : "no", b.name,
               e.symmetry, sym);
    }
    int rc = st == CLVOX_OK ? EXIT_OK : fail_status(ctx, st, ROLE_OTHER);
    clvox_palette_destroy(p);
    clvox_context_destroy(ctx);
    return rc;
}

int cmd_palette(int argc, char **argv)
{
    if (argc >= 1 && (strcmp(argv[0], "-h") == 0 || strcmp(argv[0], "--help") == 0)) {
        print_palette_help();
        return EXIT_OK;
    }
    if (argc < 1) return usage_error("palette: missing 'list' or 'show NAME|FILE'");
    if (strcmp(argv[0], "list") == 0) {
        if (argc != 1) return usage_error("palette list: unexpected argument '%s'", argv[1]);
        return cmd_list();
    }
    if (strcmp(argv[0], "show") == 0) {
        if (argc < 2) return usage_error("palette show: missing NAME or FILE");
        if (argc > 2) return usage_error("palette show: more than one palette given: '%s' and '%s'", argv[1], argv[2]);
        return cmd_show(argv[1]);
    }
    return usage_error("palette: unknown subcommand '%s' (list, show)", argv[0]);
}
