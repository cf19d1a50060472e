/* SPDX-License-Identifier: Apache-2.0 */
/* Helpers shared by the clvox command-line files (cli.c, cli_args.c,
 * cli_info.c, cli_run.c and each subcommand's cli_*.c). The CLI uses only
 * the public header. */
#ifndef CLVOX_CLI_COMMON_H
#define CLVOX_CLI_COMMON_H

#include "clvox.h"

#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__)
#define CLI_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define CLI_PRINTF(a, b)
#endif

/* Exit codes (documented in --help and README). */
enum {
    EXIT_OK = 0,
    EXIT_RUNTIME = 1,
    EXIT_USAGE = 2,
    EXIT_NO_DEVICE = 3,
    EXIT_INPUT = 4,
    EXIT_OUTPUT = 5,
    EXIT_GRID = 6,
    EXIT_CANCELLED = 130
};

/* Width of the progress line on stderr (0: none); erased by progress_erase. */
extern int g_progress_line_len;
/* Erases the progress line, if one is on screen, before anything else is
 * written to stderr. */
void progress_erase(void);

/* Prints "clvox: error: <message>" as exactly one line (newlines in the
 * message, e.g. a kernel build log, become " | "; other control bytes "?")
 * and returns `code`. */
int fail_message(int code, const char *message);
/* When set, fail_message prints "clvox: error: <prefix>: <message>" (batch
 * runs name the mesh). */
extern const char *g_fail_prefix;
/* The last message fail_message printed (without "clvox: error: " and the
 * prefix), control bytes replaced as on stderr; "" before any. */
const char *cli_last_error(void);
int fail(int code, const char *fmt, ...) CLI_PRINTF(2, 3);
/* fail(EXIT_USAGE, "<message> (see clvox --help)") */
int usage_error(const char *fmt, ...) CLI_PRINTF(1, 2);

/* What a failing call was doing decides what IO/EXR errors mean. */
typedef enum role { ROLE_INPUT, ROLE_OUTPUT, ROLE_OTHER } role;
int exit_code_for(clvox_status st, role r);
/* Reports a library failure: the context's message, else the status string. */
int fail_status(const clvox_context *ctx, clvox_status st, role r);

/* Strict unsigned parsing: returns NULL on success, else why `s` is not
 * acceptable. end_out NULL: the whole string must be the number. */
const char *parse_u32(const char *s, uint32_t min, uint32_t *out, const char **end_out);

/* Matches argv[*i] against a short and/or long option that takes a value;
 * accepts "-r 16", "-r16", "--opt 16" and "--opt=16". Returns 1 on a match
 * (*missing = 1 when the value is absent), 0 otherwise. */
int match_value(int argc, char **argv, int *i, const char *short_name, const char *long_name, const char **value,
                int *missing);

/* Fails early (creating nothing) when the output can not possibly be
 * written: a directory, anything else that is not a regular file (symbolic
 * link, device node, FIFO, socket), a name ending in '/', a missing or
 * unwritable directory. Returns EXIT_OK or the reported EXIT_OUTPUT. */
int check_output(const char *path);
/* mkdir -p of the directories `path` names before its file name (clvox
 * batch): each missing one is created (mode 0777 less the umask), one that
 * exists is kept, nothing is ever removed or replaced; a component that
 * exists and is not a directory (or a link to one) is an error. Returns
 * EXIT_OK or the reported EXIT_OUTPUT. */
int make_parent_dirs(const char *path);

/* 1 when `name` is one of the comma-separated names in `list`
 * (clvox_volume_info.channels). */
int has_channel(const char *list, const char *name);

/* "512 bytes", "1.50 MiB": a size for people. */
void format_bytes(uint64_t bytes, char *buf, size_t size);
/* count voxels of size h[0] x h[1] x h[2] (0 for no voxel, never nan). */
double voxels_volume(double count, const double h[3]);
/* A volume for the summary: %.*g, or words when it overflowed a double. */
void format_volume(double v, int digits, char *buf, size_t size);
/* The part of `path` after its last '/'. */
const char *path_basename(const char *path);
/* 1 when `path` is a regular file this process can read. */
int is_readable_file(const char *path);

/* The label column of the summaries: printf(LABEL "...", "grid", ...). */
#define LABEL "%-13s"
/* The "grid" and "filled" lines of `clvox MESH` and `clvox info`. */
void print_grid_line(const uint32_t dims[3], const double origin[3], const double h[3]);
void print_filled_line(uint64_t filled, uint64_t total);

/* fflush(stdout), keeping the first error (a later flush of an emptied
 * buffer succeeds and would lose it). */
void cli_flush_stdout(void);
/* 1 once a flush of stdout failed. */
int cli_stdout_failed(void);
/* Every command ends here: output that could not be written to stdout (a
 * full disk, a closed pipe, > /dev/full) is an error, exit 1, unless the
 * command already failed. `written` names the file a voxelization wrote. */
int cli_finish_stdout(int rc, const char *written);

/* clvox --help (cli_args.c): every subcommand and option. */
void print_help(void);

/* clvox info (cli_info.c); argv after "info". */
int cmd_info(int argc, char **argv);
/* clvox preview (cli_preview.c); argv after "preview". */
int cmd_preview(int argc, char **argv);
/* clvox palette (cli_palette.c); argv after "palette". */
int cmd_palette(int argc, char **argv);
/* clvox instances (cli_instances.c); argv after "instances". */
int cmd_instances(int argc, char **argv);
/* clvox mesh (cli_mesh.c); argv after "mesh". */
int cmd_mesh(int argc, char **argv);
/* clvox convert (cli_convert.c); argv after "convert". */
int cmd_convert(int argc, char **argv);
/* clvox batch (cli_batch.c); argv after "batch". */
int cmd_batch(int argc, char **argv);

#endif
