/* SPDX-License-Identifier: Apache-2.0 */
/*
 * clvox info FILE [--json]: a volume's header, filled voxel count,
 * coverage sum and volume, and for palette volumes the elements used, most
 * voxels first. Reads files on a host-only context (no OpenCL device). Its
 * own file, split from cli.c unchanged, because it shares nothing with a
 * voxelization but the summary's line format (cli_common.c).
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include "clvox.h"
#include "cli_common.h"
#include "cli_json.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static void info_json(const char *file, const clvox_volume_info *info, int have_size, uint64_t file_size)
{
    jbuf b;
    jb_init(&b);
    uint64_t total = (uint64_t)info->dims[0] * info->dims[1] * info->dims[2];
    jb_obj_begin(&b, NULL);
    jb_str(&b, "type", "volume");
    jb_path(&b, "file", file);
    if (have_size) jb_u64(&b, "file_size", file_size);
    else jb_null(&b, "file_size");
    jb_obj_begin(&b, "grid");
    jb_u32x3(&b, "dims", info->dims);
    jb_num3(&b, "origin", info->origin);
    jb_num3(&b, "voxel_size", info->voxel_size);
    jb_u64(&b, "voxels", total);
    jb_obj_end(&b);
    jb_str(&b, "method", info->method);
    jb_str(&b, "parameters", info->parameters);
    jb_str(&b, "version", info->version);
    jb_str(&b, "compression", info->compression);
    jb_arr_begin(&b, "channels");
    for (const char *p = info->channels; *p;) {
        size_t n = strcspn(p, ",");
        char name[64];
        snprintf(name, sizeof name, "%.*s", (int)(n < 63 ? n : 63), p);
        jb_str(&b, NULL, name);
        p += n;
        if (*p == ',') p++;
    }
    jb_arr_end(&b);
    jb_u64(&b, "filled_voxels", info->filled_voxels);
    jb_u64(&b, "total_voxels", total);
    const int cov = has_channel(info->channels, "coverage");
    if (cov) jb_num(&b, "coverage_sum", info->coverage_sum);
    else jb_null(&b, "coverage_sum");
    jb_obj_begin(&b, "volume");
    jb_num(&b, "voxels", voxels_volume((double)info->filled_voxels, info->voxel_size));
    if (cov) jb_num(&b, "coverage", voxels_volume(info->coverage_sum, info->voxel_size));
    jb_obj_end(&b);
    if (info->palette[0]) {
        char hash[24];
        snprintf(hash, sizeof hash, "%016llx", (unsigned long long)info->palette_hash);
        jb_obj_begin(&b, "palette");
        jb_str(&b, "name", info->palette);
        jb_u64(&b, "elements", info->palette_count);
        jb_str(&b, "hash", hash);
        jb_str(&b, "metric", info->metric);
        jb_obj_end(&b);
    } else {
        jb_null(&b, "palette");
    }
    jb_obj_end(&b);
    if (jb_write_line(&b) != 0 && b.oom) fail(EXIT_RUNTIME, "out of memory");
    jb_free(&b);
}

/* Voxels per element index of a file's "element" channel (slice by slice). */
#define INFO_TOP_ELEMENTS 10
typedef struct element_histogram {
    const clvox_volume_info *info; /* the header: filled in before the first slice */
    uint64_t count[65536];         /* per index (palette indices are uint16) */
    uint64_t other;                /* values that are not an index 0..65535 */
} element_histogram;

static int count_elements(void *user, uint32_t z, const float *values)
{
    element_histogram *h = user;
    (void)z;
    const size_t n = (size_t)h->info->dims[0] * h->info->dims[1];
    for (size_t i = 0; i < n; i++) {
        float v = values[i];
        if (v >= 0 && v < 65536.0f && v == floorf(v)) h->count[(uint32_t)v]++;
        else h->other++;
    }
    return 0;
}

/* The palette line and the most frequent elements of a file with an element
 * channel, named from the palette rebuilt from the header when it can be. */
static int print_elements(clvox_context *ctx, const char *file, const clvox_volume_info *info, uint64_t total)
{
    clvox_palette *pal = NULL;
    char why[1024] = "";
    if (info->palette[0]) {
        if (clvox_volume_palette(ctx, file, &pal) != CLVOX_OK)
            snprintf(why, sizeof why, "%s", clvox_context_error(ctx));
        printf(LABEL "%s: %u elements, hash %016llx, metric %s%s%s\n", "palette", info->palette, info->palette_count,
               (unsigned long long)info->palette_hash, info->metric[0] ? info->metric : "?",
               why[0] ? "; cannot be rebuilt: " : "", why);
    }
    element_histogram *h = calloc(1, sizeof *h);
    if (!h) {
        clvox_palette_destroy(pal);
        return fail(EXIT_RUNTIME, "out of memory");
    }
    clvox_volume_info again = CLVOX_VOLUME_INFO_INIT;
    h->info = &again;
    clvox_status st = clvox_volume_read_slices(ctx, file, "element", &again, count_elements, h);
    if (st != CLVOX_OK) {
        int rc = fail_status(ctx, st, ROLE_INPUT);
        free(h);
        clvox_palette_destroy(pal);
        return rc;
    }
    uint32_t top[INFO_TOP_ELEMENTS];
    size_t ntop = 0, used = 0;
    for (uint32_t e = 0; e < 65536u; e++) {
        if (!h->count[e]) continue;
        used++;
        /* insertion into the top list: most voxels first, then the lower index */
        size_t k = ntop < INFO_TOP_ELEMENTS ? ntop++ : INFO_TOP_ELEMENTS;
        while (k > 0 && h->count[top[k - 1]] < h->count[e]) {
            if (k < INFO_TOP_ELEMENTS) top[k] = top[k - 1];
            k--;
        }
        if (k < INFO_TOP_ELEMENTS) top[k] = e;
    }
    char of[48] = "";
    if (info->palette_count) snprintf(of, sizeof of, " of %u", info->palette_count);
    printf(LABEL "%zu%s used; voxels per element, most first:\n", "elements", used, of);
    uint64_t shown = 0;
    for (size_t k = 0; k < ntop; k++) {
        uint32_t e = top[k];
        clvox_palette_element_info ei = CLVOX_PALETTE_ELEMENT_INFO_INIT;
        const char *name = "";
        if (pal && clvox_palette_element_info_get(ctx, pal, e, &ei) == CLVOX_OK) name = ei.name;
        else if (pal) name = "(not in the palette)";
        printf("%13s%5u %-24s %12llu  %6.2f %%\n", "", (unsigned)e, name, (unsigned long long)h->count[e],
               total ? 100.0 * (double)h->count[e] / (double)total : 0.0);
        shown += h->count[e];
    }
    if (used > ntop) {
        uint64_t rest = total - shown - h->other;
        printf("%13s%zu more elements: %llu voxels (%.2f %%)\n", "", used - ntop, (unsigned long long)rest,
               total ? 100.0 * (double)rest / (double)total : 0.0);
    }
    if (h->other)
        printf("%13s%llu voxels hold no element index (not an integer 0..65535)\n", "",
               (unsigned long long)h->other);
    free(h);
    clvox_palette_destroy(pal);
    return EXIT_OK;
}

int cmd_info(int argc, char **argv)
{
    const char *file = NULL;
    int json = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            print_help();
            return EXIT_OK;
        }
        if (strcmp(a, "--json") == 0) {
            json = 1;
            continue;
        }
        if (a[0] == '-' && a[1] != '\0') return usage_error("info: unknown option '%s'", a);
        if (file) return usage_error("info: more than one file given: '%s' and '%s'", file, a);
        file = a;
    }
    if (!file) return usage_error("info: missing FILE (a volume: EXR, npy, NRRD, binvox or OpenVDB)");

    clvox_context *ctx = NULL;
    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_status st = clvox_context_create(&co, &ctx);
    if (st != CLVOX_OK) {
        int rc = fail_status(ctx, st, ROLE_OTHER);
        clvox_context_destroy(ctx);
        return rc;
    }
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    st = clvox_volume_read(ctx, file, &info, NULL, 0);
    if (st != CLVOX_OK) {
        int rc = fail_status(ctx, st, ROLE_INPUT);
        clvox_context_destroy(ctx);
        return rc;
    }

    struct stat sb;
    char size[48] = "?";
    int have_size = stat(file, &sb) == 0;
    if (have_size) format_bytes((uint64_t)sb.st_size, size, sizeof size);
    if (json) {
        info_json(file, &info, have_size, have_size ? (uint64_t)sb.st_size : 0);
        clvox_context_destroy(ctx);
        return EXIT_OK;
    }
    uint64_t total = (uint64_t)info.dims[0] * info.dims[1] * info.dims[2];

    printf(LABEL "%s (%s)\n", "file", file, size);
    print_grid_line(info.dims, info.origin, info.voxel_size);
    printf(LABEL "%s%s%s%s\n", "method", info.method[0] ? info.method : "?", info.parameters[0] ? " (" : "",
           info.parameters, info.parameters[0] ? ")" : "");
    printf(LABEL "clvox %s\n", "written by", info.version[0] ? info.version : "?");
    printf(LABEL "%s, channels %s\n", "compression", info.compression[0] ? info.compression : "?",
           info.channels[0] ? info.channels : "?");
    print_filled_line(info.filled_voxels, total);
    char vol[48];
    if (has_channel(info.channels, "coverage")) {
        format_volume(voxels_volume(info.coverage_sum, info.voxel_size), 9, vol, sizeof vol);
        printf(LABEL "%.9g voxels (sum of coverage), estimated volume %s (sum x voxel volume)\n", "coverage",
               info.coverage_sum, vol);
    }
    format_volume(voxels_volume((double)info.filled_voxels, info.voxel_size), 6, vol, sizeof vol);
    printf(LABEL "%s (filled voxels x voxel volume)\n", "volume", vol);
    int rc = EXIT_OK;
    if (has_channel(info.channels, "element")) rc = print_elements(ctx, file, &info, total);
    else if (info.palette[0])
        printf(LABEL "%s: %u elements, hash %016llx, metric %s (no element channel)\n", "palette", info.palette,
               info.palette_count, (unsigned long long)info.palette_hash, info.metric[0] ? info.metric : "?");
    clvox_context_destroy(ctx);
    return rc;
}
