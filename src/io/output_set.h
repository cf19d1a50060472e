/* SPDX-License-Identifier: Apache-2.0 */
/* Is an output complete? (output_set.c). Library-internal (not installed),
 * shared with the CLI (batch --skip-existing, --like): no OpenCL types. */
#ifndef CLVOX_OUTPUT_SET_H
#define CLVOX_OUTPUT_SET_H

#include <stddef.h>

/* 1 when the output clvox names `path` can be trusted as the whole result of
 * one run: a regular file, and where it belongs to a set (npy: OUT.json and
 * the channels' files; NRRD with several channels: OUT.nrrd and
 * OUT.<channel>.nrrd), every member agrees with the size and CRC-32 its marker
 * records. 0 otherwise, with one line in `why` (no such file; not a regular
 * file; a member that does not match, as a failed or killed run leaves; a
 * marker without identities, as earlier clvox versions wrote). */
int clvox__output_complete(const char *path, char *why, size_t why_size);

/* The same for the npy set whose marker is `json`: every member it lists
 * agrees, and `member` (NULL: any), when given, is one of them. */
int clvox__npy_set_complete(const char *json, const char *member, char *why, size_t why_size);

/* OUT.json as the npy reader needs it (read_volume.c): the grid, method,
 * parameters and, per channel, the file beside it and how it is stored.
 * Returns 1, or 0 for text that is not a clvox npy sidecar. */
typedef struct clvox__npy_sidecar {
    int have_dims, have_origin, have_voxel_size;
    double dims[3], origin[3], voxel_size[3];
    char version[32], method[32], parameters[256];
    size_t nchannels;
    struct {
        char name[16], file[256], dtype[8];
        int packed_bits;
    } ch[4];
} clvox__npy_sidecar;
int clvox__npy_sidecar_parse(const char *text, size_t len, clvox__npy_sidecar *out);

#endif
