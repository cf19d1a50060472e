/* SPDX-License-Identifier: Apache-2.0 */
/* NumPy .npy (format 1.0) writer: one file per channel, shape (Z, Y, X) in
 * C order (x fastest), streamed slab by slab: the header knows the shape up
 * front. occupancy |u1 0/1, or with CLVOX_OUTPUT_PACK_BITS |u1 (Z, Y,
 * ceil(X/8)) bits along x, bit x%8 of byte x/8 (np.unpackbits(a, axis=2,
 * bitorder='little')[:, :, :X]); coverage and score <f2 (the EXR file's HALF
 * values) or <f4 (exactly count/samples) with CLVOX_OUTPUT_FLOAT32; element
 * <u2, or <u4 with CLVOX_OUTPUT_UINT32. Files: OUT.npy holds the main
 * channel (occupancy, else element, else coverage), the others
 * OUT.<channel>.npy; OUT.json describes the grid and is the set's marker,
 * named last, with each file's size and CRC-32 (docs/formats.md). */
#include "write_raster.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static clvox__dtype npy_dtype(const clvox__fmt_info *info, uint32_t channel)
{
    switch (channel) {
    case CLVOX_CHANNEL_OCCUPANCY: return (info->flags & CLVOX_OUTPUT_PACK_BITS) ? CLVOX__BITS : CLVOX__U8;
    case CLVOX_CHANNEL_ELEMENT: return (info->flags & CLVOX_OUTPUT_UINT32) ? CLVOX__U32 : CLVOX__U16;
    default: return (info->flags & CLVOX_OUTPUT_FLOAT32) ? CLVOX__F32 : CLVOX__F16;
    }
}

static const char *npy_descr(clvox__dtype t)
{
    switch (t) {
    case CLVOX__U8: case CLVOX__BITS: return "|u1";
    case CLVOX__F16: return "<f2";
    case CLVOX__F32: return "<f4";
    case CLVOX__U16: return "<u2";
    default: return "<u4";
    }
}

static clvox_status npy_header(clvox_context *ctx, const clvox__fmt_info *info, uint32_t channel, clvox__dtype t,
                               const char *file, void *user, const char *set_line, char **out, size_t *len)
{
    (void)channel, (void)file, (void)user, (void)set_line; /* the set's marker is the sidecar */
    const clvox_grid *g = info->grid;
    unsigned long long last = t == CLVOX__BITS ? ((unsigned long long)g->dims[0] + 7) / 8 : g->dims[0];
    char dict[256];
    int n = snprintf(dict, sizeof dict, "{'descr': '%s', 'fortran_order': False, 'shape': (%u, %u, %llu), }",
                     npy_descr(t), g->dims[2], g->dims[1], last);
    size_t total = 10 + (size_t)n + 1;
    total = (total + 63) / 64 * 64; /* magic + dict + '\n' padded to 64 bytes */
    char *h = malloc(total);
    if (!h) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    memcpy(h, "\x93NUMPY\x01\x00", 8);
    size_t hl = total - 10;
    h[8] = (char)(hl & 0xFF);
    h[9] = (char)(hl >> 8);
    memcpy(h + 10, dict, (size_t)n);
    memset(h + 10 + n, ' ', total - 10 - (size_t)n - 1);
    h[total - 1] = '\n';
    *out = h;
    *len = total;
    return CLVOX_OK;
}

/* Appends s as a JSON string. */
static void json_str(char *buf, size_t size, size_t *at, const char *s)
{
    if (*at + 1 >= size) return;
    buf[(*at)++] = '"';
    for (; s && *s && *at + 8 < size; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') buf[(*at)++] = '\\', buf[(*at)++] = (char)c;
        else if (c < 0x20) *at += (size_t)snprintf(buf + *at, size - *at, "\\u%04x", c);
        else buf[(*at)++] = (char)c;
    }
    if (*at + 1 < size) buf[(*at)++] = '"';
    buf[*at] = '\0';
}

#define JSON_ADD(...) do { if (at < size) at += (size_t)snprintf(j + at, size - at, __VA_ARGS__); } while (0)

/* OUT.json, the set's marker (named last): the grid, and for each channel its
 * file with that file's size and CRC-32, which readers and batch
 * --skip-existing compare with the files (output_set.c). */
static clvox_status npy_sidecar(clvox_context *ctx, const clvox__fmt_info *info, const clvox__raster_member *m,
                                size_t nm, void *user, char **text)
{
    (void)user;
    const clvox_grid *g = info->grid;
    size_t size = 4096;
    char *j = malloc(size);
    if (!j) return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory");
    size_t at = 0;
    JSON_ADD("{\n  \"clvox_version\": \"%s\",\n  \"format\": \"npy\",\n", CLVOX_VERSION_STRING);
    JSON_ADD("  \"dims\": [%u, %u, %u],\n  \"shape\": [%u, %u, %u],\n", g->dims[0], g->dims[1], g->dims[2],
             g->dims[2], g->dims[1], g->dims[0]);
    JSON_ADD("  \"origin\": [%.17g, %.17g, %.17g],\n", g->origin[0], g->origin[1], g->origin[2]);
    JSON_ADD("  \"voxel_size\": [%.17g, %.17g, %.17g],\n", g->voxel_size[0], g->voxel_size[1], g->voxel_size[2]);
    JSON_ADD("  \"convention\": \"array[z, y, x] is voxel (x, y, z), centre origin + (i + 0.5) * voxel_size\",\n");
    JSON_ADD("  \"method\": ");
    json_str(j, size, &at, info->method);
    JSON_ADD(",\n  \"parameters\": ");
    json_str(j, size, &at, info->parameters);
    JSON_ADD(",\n  \"channels\": {");
    for (size_t i = 0; i < nm; i++) {
        const char *base = strrchr(m[i].path, '/') ? strrchr(m[i].path, '/') + 1 : m[i].path;
        clvox__dtype t = npy_dtype(info, m[i].channel);
        JSON_ADD("%s\n    \"%s\": {\"file\": ", i ? "," : "", clvox__channel_name(m[i].channel));
        json_str(j, size, &at, base);
        JSON_ADD(", \"dtype\": \"%s\", \"packed_bits\": %s, \"bytes\": %llu, \"crc32\": \"%08x\"}", npy_descr(t) + 1,
                 t == CLVOX__BITS ? "true" : "false", (unsigned long long)m[i].bytes, (unsigned)m[i].crc32);
    }
    JSON_ADD("\n  }\n}\n");
    if (at >= size) {
        free(j);
        return clvox__fail(ctx, CLVOX_ERR_INVALID_ARGUMENT, "the sidecar of '%s' is too long", m[0].path);
    }
    *text = j;
    return CLVOX_OK;
}

static const clvox__raster_spec npy_spec = {0, npy_dtype, npy_header, ".json", npy_sidecar};

static clvox_status npy_open(clvox_context *ctx, const clvox__fmt_info *info, void **state)
{
    return clvox__raster_open(ctx, info, &npy_spec, NULL, (clvox__raster **)state);
}
static clvox_status npy_write(void *state, const clvox__fmt_slab *s) { return clvox__raster_write(state, s); }
static clvox_status npy_finish(void *state, uint64_t *bytes) { return clvox__raster_finish(state, bytes); }
static void npy_abort(void *state) { clvox__raster_abort(state); }

const clvox__fmt_ops clvox__fmt_npy = {
    "npy", CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE | CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE, 1, 0,
    npy_open, npy_write, npy_finish, npy_abort};
