/* SPDX-License-Identifier: Apache-2.0 */
/* clvox convert IN OUT.{npy,nrrd,binvox,vdb,exr}: rewrites a clvox volume (any format)
 * in another format in bounded memory: each channel is streamed slice by
 * slice (clvox_volume_read_slices) into a clvox_volume_writer, so memory is
 * one slice per channel plus the writer's (binvox: the whole volume as bits,
 * its voxel order runs x slowest). Needs no OpenCL device. */
#include "cli_common.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

typedef struct convert_state {
    clvox_volume_writer *w;
    uint32_t channel;
    clvox_status st;
    const clvox_context *ctx;
    char why[1024]; /* the writer's message: the reader's "cancelled" replaces it in the context */
} convert_state;

static int stop_at_once(void *user, uint32_t z, const float *values)
{
    (void)user, (void)z, (void)values;
    return 1;
}

static int put_slice(void *user, uint32_t z, const float *values)
{
    convert_state *s = user;
    s->st = clvox_volume_writer_slice(s->w, s->channel, z, values);
    if (s->st == CLVOX_OK) return 0;
    const char *msg = clvox_context_error(s->ctx);
    snprintf(s->why, sizeof s->why, "%s", msg && *msg ? msg : clvox_status_string(s->st));
    return 1;
}

static uint32_t channel_bit(const char *name)
{
    if (strcmp(name, "occupancy") == 0) return CLVOX_CHANNEL_OCCUPANCY;
    if (strcmp(name, "coverage") == 0) return CLVOX_CHANNEL_COVERAGE;
    if (strcmp(name, "element") == 0) return CLVOX_CHANNEL_ELEMENT;
    if (strcmp(name, "score") == 0) return CLVOX_CHANNEL_SCORE;
    return 0;
}

static const char *const channel_names[4] = {"occupancy", "coverage", "element", "score"};

int cmd_convert(int argc, char **argv)
{
    const char *in = NULL, *out = NULL, *v = NULL;
    clvox_output_options oo = CLVOX_OUTPUT_OPTIONS_INIT;
    uint32_t want = 0;
    for (int i = 0; i < argc; i++) {
        int missing = 0;
        if (match_value(argc, argv, &i, NULL, "--format", &v, &missing)) {
            if (missing) return usage_error("convert: --format needs a value");
            if (!(oo.format = clvox_format_from_name(v)))
                return usage_error("convert: --format '%s': one of exr, npy, nrrd, binvox, vdb", v);
        } else if (match_value(argc, argv, &i, NULL, "--channel", &v, &missing)) {
            if (missing) return usage_error("convert: --channel needs a value");
            uint32_t b = channel_bit(v);
            if (!b) return usage_error("convert: --channel '%s': one of occupancy, coverage, element, score", v);
            want |= b;
        } else if (match_value(argc, argv, &i, NULL, "--compression", &v, &missing)) {
            if (missing) return usage_error("convert: --compression needs a value");
            static const char *const names[] = {"none", "rle", "zips", "zip", "piz"};
            static const clvox_compression vals[] = {CLVOX_COMPRESSION_NONE, CLVOX_COMPRESSION_RLE,
                                                     CLVOX_COMPRESSION_ZIPS, CLVOX_COMPRESSION_ZIP,
                                                     CLVOX_COMPRESSION_PIZ};
            int found = 0;
            for (int k = 0; k < 5; k++)
                if (strcmp(v, names[k]) == 0) oo.compression = vals[k], found = 1;
            if (!found) return usage_error("convert: --compression '%s': none, rle, zip, zips or piz", v);
        } else if (strcmp(argv[i], "--npy-bits") == 0) {
            oo.flags |= CLVOX_OUTPUT_PACK_BITS;
        } else if (strcmp(argv[i], "--npy-float32") == 0) {
            oo.flags |= CLVOX_OUTPUT_FLOAT32;
        } else if (strcmp(argv[i], "--npy-uint32") == 0) {
            oo.flags |= CLVOX_OUTPUT_UINT32;
        } else if (argv[i][0] == '-' && argv[i][1]) {
            return usage_error("convert: unknown option '%s'", argv[i]);
        } else if (!in) {
            in = argv[i];
        } else if (!out) {
            out = argv[i];
        } else {
            return usage_error("convert: more than two files given ('%s')", argv[i]);
        }
    }
    if (!in || !out) return usage_error("convert: usage: clvox convert IN OUT.{npy,nrrd,binvox,vdb,exr}");
    int rc = check_output(out);
    if (rc != EXIT_OK) return rc;
    clvox_format format = oo.format ? oo.format : clvox_format_from_path(out);
    if (!format)
        return usage_error("convert: cannot tell the output format of '%s' from its extension: use .exr, .npy, .nrrd, "
                           ".binvox or .vdb, or --format",
                           out);
    oo.format = format;
    struct stat si, so;
    if (stat(in, &si) == 0 && stat(out, &so) == 0 && si.st_dev == so.st_dev && si.st_ino == so.st_ino)
        return usage_error("convert: the output '%s' is the input", out);

    clvox_context_options co = CLVOX_CONTEXT_OPTIONS_INIT;
    co.host_only = 1;
    clvox_context *ctx = NULL;
    clvox_status st = clvox_context_create(&co, &ctx);
    if (st != CLVOX_OK) {
        rc = fail_status(ctx, st, ROLE_OTHER);
        clvox_context_destroy(ctx);
        return rc;
    }
    clvox_volume_info info = CLVOX_VOLUME_INFO_INIT;
    /* the header only: info is filled before the first slice, which stops the read */
    st = clvox_volume_read_slices(ctx, in, "occupancy", &info, stop_at_once, NULL);
    if (st == CLVOX_ERR_EXR && info.dims[0] && !has_channel(info.channels, "occupancy")) st = CLVOX_ERR_CANCELLED;
    if (st != CLVOX_ERR_CANCELLED && st != CLVOX_OK) {
        rc = fail_status(ctx, st, ROLE_INPUT);
        clvox_context_destroy(ctx);
        return rc;
    }
    uint32_t have = 0;
    for (int k = 0; k < 4; k++)
        if (has_channel(info.channels, channel_names[k])) have |= 1u << k;
    if (want & ~have) {
        for (int k = 0; k < 4; k++)
            if ((want & ~have) & (1u << k)) {
                rc = fail(EXIT_INPUT, "convert: '%s' has no %s channel (has: %s)", in, channel_names[k], info.channels);
                break;
            }
        clvox_context_destroy(ctx);
        return rc;
    }
    if (!want) { /* default: every channel where each channel has its own file, else the main one */
        if (format == CLVOX_FORMAT_NPY || format == CLVOX_FORMAT_NRRD) want = have;
        /* vdb: density = coverage when there is one (+ an occupancy grid), as clvox MESH -o OUT.vdb */
        else if (format == CLVOX_FORMAT_VDB && (have & (CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE)))
            want = have & (CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE);
        else want = (have & CLVOX_CHANNEL_OCCUPANCY) ? CLVOX_CHANNEL_OCCUPANCY
                    : (have & CLVOX_CHANNEL_ELEMENT) ? CLVOX_CHANNEL_ELEMENT
                                                     : (have & CLVOX_CHANNEL_COVERAGE);
    }
    if (!want) {
        rc = fail(EXIT_INPUT, "convert: '%s' has no clvox channel (has: %s)", in, info.channels);
        clvox_context_destroy(ctx);
        return rc;
    }
    clvox_grid grid;
    memcpy(grid.dims, info.dims, sizeof grid.dims);
    memcpy(grid.origin, info.origin, sizeof grid.origin);
    memcpy(grid.voxel_size, info.voxel_size, sizeof grid.voxel_size);
    oo.method = info.method;
    oo.parameters = info.parameters;
    clvox_volume_writer *w = NULL;
    st = clvox_volume_writer_open(ctx, out, &grid, want, &oo, &w);
    if (st != CLVOX_OK) {
        rc = fail_status(ctx, st, ROLE_OUTPUT);
        clvox_context_destroy(ctx);
        return rc;
    }
    for (int k = 0; k < 4 && st == CLVOX_OK; k++) {
        if (!(want & (1u << k))) continue;
        convert_state cs = {w, 1u << k, CLVOX_OK, ctx, ""};
        st = clvox_volume_read_slices(ctx, in, channel_names[k], NULL, put_slice, &cs);
        if (st == CLVOX_ERR_CANCELLED && cs.st != CLVOX_OK) {
            st = cs.st;
            rc = fail_message(exit_code_for(st, ROLE_OUTPUT), cs.why);
        } else if (st != CLVOX_OK) {
            rc = fail_status(ctx, st, ROLE_INPUT);
        }
    }
    uint64_t bytes = 0;
    if (st == CLVOX_OK) {
        st = clvox_volume_writer_finish(w, &bytes);
        if (st != CLVOX_OK) rc = fail_status(ctx, st, ROLE_OUTPUT);
    } else {
        clvox_volume_writer_abort(w);
    }
    if (st == CLVOX_OK) {
        printf("converted    %s -> %s (%s, %u x %u x %u, %llu bytes)\n", in, out, clvox_format_name(format),
               grid.dims[0], grid.dims[1], grid.dims[2], (unsigned long long)bytes);
        rc = EXIT_OK;
    }
    clvox_context_destroy(ctx);
    return rc;
}
