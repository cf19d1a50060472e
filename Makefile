# SPDX-License-Identifier: Apache-2.0
# clvox — build, test, install.
#   make [CONFIG=release|debug|sanitize|tsan] [V=1]  library, clvox binary
#                                                  (tsan: ThreadSanitizer, scripts/check_threads.sh)
#   make test                                      build and run the test suite
#   make bench-tools                               the benchmarks' C helpers (scripts/bench/README.md)
#   make install PREFIX=/usr/local DESTDIR=
CONFIG ?= release
PREFIX ?= /usr/local
DESTDIR ?=
V ?= 0

CC ?= cc
CXX ?= c++
BUILD := build/$(CONFIG)

WARN := -Wall -Wextra -Wpedantic -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wvla
# -Isrc (the library's internal headers) only for the library, the tests
# and the fuzz targets: the CLI (src/cli) is compiled with -Iinclude alone,
# so it can use nothing but the public clvox.h.
BASE_CFLAGS := -std=c11 -D_POSIX_C_SOURCE=200809L -fPIC -ffp-contract=off $(WARN) -Iinclude
BASE_CXXFLAGS := -std=c++17 -fPIC -Wall -Wextra -Iinclude -Isrc
ifeq ($(CONFIG),release)
  OPT := -O2 -g
else ifeq ($(CONFIG),debug)
  OPT := -O0 -g3
else ifeq ($(CONFIG),sanitize)
  OPT := -O1 -g -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
  SAN_LDFLAGS := -fsanitize=address,undefined
else ifeq ($(CONFIG),tsan)
  OPT := -O1 -g -fsanitize=thread -fno-omit-frame-pointer
  SAN_LDFLAGS := -fsanitize=thread
else
  $(error CONFIG must be release, debug, sanitize or tsan)
endif
# User flags come last so they win (redis FINAL_CFLAGS).
FINAL_CFLAGS := $(BASE_CFLAGS) $(OPT) $(CFLAGS)
FINAL_CXXFLAGS := $(BASE_CXXFLAGS) $(OPT) -Wno-maybe-uninitialized $(CXXFLAGS)
# Assimp (Debian libassimp-dev) reads the formats clvox has no reader of its
# own for (glTF, 3MF, FBX, DAE, ...: src/mesh/mesh_assimp.cpp).
ASSIMP_CFLAGS := $(shell pkg-config --cflags assimp 2>/dev/null)
ASSIMP_LIBS := $(shell pkg-config --libs assimp 2>/dev/null || echo -lassimp)
BASE_CXXFLAGS += $(ASSIMP_CFLAGS)
LIBS := -lOpenCL -lOpenEXRCore-3_1 -lOpenMeshCore $(ASSIMP_LIBS) -lz -lstdc++ -lm -lpthread -ldl
# libpng (Debian libpng-dev) only for `clvox preview` in the CLI and for the
# tests that decode its pictures; the library does not use it.
PNG_LIBS := -lpng
# GMP (Debian libgmp-dev) only for the tests: exact rational references.
TEST_LIBS := -lgmp
FINAL_LDFLAGS := $(SAN_LDFLAGS) $(LDFLAGS)
# OpenVDB (Debian libopenvdb-dev) for .vdb output, optional: found when its
# header and library are there; WITH_OPENVDB=0 builds without it (.vdb is then
# refused with "clvox was built without OpenVDB"), WITH_OPENVDB=1 insists.
OPENVDB_FOUND := $(shell printf '\043include <openvdb/openvdb.h>\n' | $(CXX) -std=c++17 -E -x c++ - >/dev/null 2>&1 && \
  printf 'int main(){return 0;}' | $(CXX) -x c++ - -o /dev/null -lopenvdb >/dev/null 2>&1 && echo 1 || echo 0)
# The sanitize build has it too: linked in, libopenvdb's log4cplus thread
# pool started at load time and LeakSanitizer hung at exit in the children
# test_fuzz_smoke forks; as a plugin it is loaded only by runs that write a
# .vdb.
WITH_OPENVDB ?= $(OPENVDB_FOUND)
ifeq ($(WITH_OPENVDB)$(OPENVDB_FOUND),10)
  $(error WITH_OPENVDB=1 but OpenVDB (openvdb/openvdb.h with Boost, -lopenvdb) was not found: apt-get install libopenvdb-dev libboost-dev)
endif
# The writer (src/io/write_vdb.cpp) is a plugin, $(BUILD)/libclvox-vdb.so, that
# the library loads on the first .vdb (src/io/vdb_plugin.c): linked in, OpenVDB
# cost every run 27 MB of memory and 40 ms at start. Neither the library nor
# the programs link -lopenvdb. `make install` puts it in PREFIX/lib/clvox.
VDB_PLUGIN :=
ifeq ($(WITH_OPENVDB),1)
  FINAL_CFLAGS += -DCLVOX_HAVE_OPENVDB
  VDB_PLUGIN := $(BUILD)/libclvox-vdb.so
endif
VDB_LIBS := -lopenvdb -lImath-3_1 -ltbb
# A changed choice rebuilds the loader. It looks for the plugin beside the
# library or the program (installed: lib/clvox/), then in this build's
# directory (for programs elsewhere that link this build's libclvox.a, such
# as the Python extension).
.DEFAULT_GOAL := all
OPENVDB_STAMP := $(BUILD)/gen/openvdb-$(WITH_OPENVDB)
$(OPENVDB_STAMP):
	@mkdir -p $(dir $@) && rm -f $(BUILD)/gen/openvdb-* && touch $@
$(BUILD)/src/io/vdb_plugin.o: $(OPENVDB_STAMP)
$(BUILD)/src/io/vdb_plugin.o: FINAL_CFLAGS += -DCLVOX_VDB_PLUGIN_DIR='"$(abspath $(BUILD))"'

ifeq ($(V),1)
  Q :=
else
  Q := @
endif

CLI_SRC := $(wildcard src/cli/*.c)
LIB_C := $(wildcard src/*.c) $(filter-out src/cli/%,$(wildcard src/*/*.c))
# The batch manifest parser and what it calls (fuzz_manifest, test_fuzz_smoke).
MANIFEST_CLI_SRC := src/cli/cli_manifest.c src/cli/cli_args.c src/cli/cli_common.c
LIB_CXX := $(filter-out src/io/write_vdb.cpp,$(wildcard src/*/*.cpp))
# Kernel program = shared types + prelude + sampler + palette + overlap + winding + one file per stage.
# The winding parts in this order: each uses only what comes before it.
KERNEL_WINDING := kernels/winding_angles.h kernels/winding_bounds.h kernels/winding_inside.h kernels/winding_rims.h \
  kernels/winding_lattice.h
KERNEL_FILES := kernels/clvox_types.h kernels/prelude.cl kernels/sampler.h kernels/palette.h kernels/overlap.h $(KERNEL_WINDING) $(filter-out kernels/prelude.cl,$(sort $(wildcard kernels/*.cl)))
KERNEL_C := $(BUILD)/gen/kernels_embedded.c

LIB_OBJ := $(LIB_C:%.c=$(BUILD)/%.o) $(LIB_CXX:%.cpp=$(BUILD)/%.o) $(BUILD)/gen/kernels_embedded.o
CLI_OBJ := $(CLI_SRC:%.c=$(BUILD)/%.o)
# The library's objects see its internal headers and export only what
# clvox.h marks CLVOX_API: libclvox.so's dynamic symbols are the public API.
# Programs linking libclvox.a (the CLI, the tests, the Python extension)
# still reach the clvox__* internals: hidden is not static.
LIB_VISIBILITY := -fvisibility=hidden -DCLVOX_BUILD_LIBRARY
$(LIB_OBJ): FINAL_CFLAGS += -Isrc $(LIB_VISIBILITY)
$(LIB_OBJ): FINAL_CXXFLAGS += $(LIB_VISIBILITY)
$(TEST_SUPPORT_OBJ): FINAL_CFLAGS += -Isrc
TEST_SUPPORT := $(filter-out tests/test_%.c,$(wildcard tests/*.c))
TEST_SUPPORT_OBJ := $(TEST_SUPPORT:%.c=$(BUILD)/%.o)
TEST_SRCS := $(wildcard tests/test_*.c)
TEST_BINS := $(TEST_SRCS:tests/%.c=$(BUILD)/tests/%)

STATIC_LIB := $(BUILD)/libclvox.a
SHARED_LIB := $(BUILD)/libclvox.so
CLI_BIN := $(BUILD)/clvox
DEPS := $(LIB_OBJ:.o=.d) $(CLI_OBJ:.o=.d) $(TEST_SUPPORT_OBJ:.o=.d) $(TEST_BINS:%=%.d) $(BUILD)/vdb/write_vdb.d

.PHONY: all test check install uninstall clean bench bench-tools bench-prep-base tests fuzz fuzz-run
all: $(STATIC_LIB) $(SHARED_LIB) $(CLI_BIN) $(VDB_PLUGIN)
	$(Q)ln -sf $(CONFIG)/clvox build/clvox

$(BUILD)/%.o: %.c
	@mkdir -p $(dir $@)
	@$(if $(filter 0,$(V)),echo "  CC    $<")
	$(Q)$(CC) $(FINAL_CFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/%.o: %.cpp
	@mkdir -p $(dir $@)
	@$(if $(filter 0,$(V)),echo "  CXX   $<")
	$(Q)$(CXX) $(FINAL_CXXFLAGS) -MMD -MP -c $< -o $@

$(KERNEL_C): $(KERNEL_FILES) scripts/embed_kernels.sh
	@mkdir -p $(dir $@)
	@$(if $(filter 0,$(V)),echo "  EMBED kernels/")
	$(Q)sh scripts/embed_kernels.sh $@ $(KERNEL_FILES)

$(BUILD)/gen/kernels_embedded.o: $(KERNEL_C)
	$(Q)$(CC) -std=c11 -fPIC -fvisibility=hidden $(OPT) -c $< -o $@

# The plugin: no undefined symbol (it calls the library only through the
# table it is handed, src/io/vdb_plugin.c, so it needs none of the library's
# now hidden clvox__ symbols), loaded RTLD_LOCAL by the library alone; nothing
# links against it. Default visibility, unlike the library's objects:
# compiled with -fvisibility=hidden, OpenVDB's own templates bound to the
# plugin's copies and openvdb::initialize() crashed.
$(BUILD)/vdb/write_vdb.o: src/io/write_vdb.cpp $(OPENVDB_STAMP)
	@mkdir -p $(dir $@)
	@$(if $(filter 0,$(V)),echo "  CXX   $< (plugin)")
	$(Q)$(CXX) $(FINAL_CXXFLAGS) -DCLVOX_HAVE_OPENVDB -MMD -MP -c $< -o $@

$(BUILD)/libclvox-vdb.so: $(BUILD)/vdb/write_vdb.o
	@$(if $(filter 0,$(V)),echo "  LD    $@")
	$(Q)$(CXX) -shared -Wl,--no-undefined $(FINAL_LDFLAGS) -o $@ $^ $(VDB_LIBS)

$(STATIC_LIB): $(LIB_OBJ)
	@$(if $(filter 0,$(V)),echo "  AR    $@")
	$(Q)rm -f $@ && ar rcs $@ $^
	$(Q)echo '$(LIBS)' > $(BUILD)/libclvox.libs

$(SHARED_LIB): $(LIB_OBJ) src/libclvox.map
	@$(if $(filter 0,$(V)),echo "  LD    $@")
	$(Q)$(CC) -shared -Wl,-soname,libclvox.so.$(word 1,$(subst ., ,$(shell sed -n 's/.*CLVOX_VERSION_STRING "\(.*\)"/\1/p' include/clvox.h))) -Wl,--version-script=src/libclvox.map $(FINAL_LDFLAGS) -o $@ $(LIB_OBJ) $(LIBS)

$(CLI_BIN): $(CLI_OBJ) $(STATIC_LIB)
	@$(if $(filter 0,$(V)),echo "  LD    $@")
	$(Q)$(CC) $(FINAL_LDFLAGS) -o $@ $(CLI_OBJ) $(STATIC_LIB) $(LIBS) $(PNG_LIBS)

# test_fuzz_smoke replays the manifest target: it links that CLI code.
TEST_CLI_test_fuzz_smoke := $(MANIFEST_CLI_SRC:%.c=$(BUILD)/%.o)
$(BUILD)/tests/test_fuzz_smoke: $(TEST_CLI_test_fuzz_smoke)

$(BUILD)/tests/%: tests/%.c $(TEST_SUPPORT_OBJ) $(STATIC_LIB)
	@mkdir -p $(dir $@)
	@$(if $(filter 0,$(V)),echo "  TEST  $<")
	$(Q)$(CC) $(FINAL_CFLAGS) -Isrc -Itests -MMD -MP $(FINAL_LDFLAGS) -o $@ $< $(TEST_SUPPORT_OBJ) $(TEST_CLI_$*) $(STATIC_LIB) $(LIBS) $(PNG_LIBS) $(TEST_LIBS)

# The Python package's tests (python/tests) run as one more test program.
$(BUILD)/tests/test_python: tests/test_python.sh
	@mkdir -p $(dir $@)
	$(Q)cp $< $@ && chmod +x $@

# Every kernel path under Oclgrind (tests/test_oclgrind.sh), one more test program.
$(BUILD)/tests/test_oclgrind: tests/test_oclgrind.sh
	@mkdir -p $(dir $@)
	$(Q)cp $< $@ && chmod +x $@

# scripts/tools/slurm_batch.sh under a private single-node Slurm (tests/test_slurm.sh).
$(BUILD)/tests/test_slurm: tests/test_slurm.sh
	@mkdir -p $(dir $@)
	$(Q)cp $< $@ && chmod +x $@

# README.md's commands and clvox --help's examples (tests/test_readme.sh), one more test program.
$(BUILD)/tests/test_readme: tests/test_readme.sh
	@mkdir -p $(dir $@)
	$(Q)cp $< $@ && chmod +x $@

tests: all $(TEST_BINS) $(BUILD)/tests/test_python $(BUILD)/tests/test_oclgrind $(BUILD)/tests/test_slurm \
       $(BUILD)/tests/test_readme

# Keep the support objects (make would delete them as intermediates).
.SECONDARY: $(TEST_SUPPORT_OBJ)

# The whole suite; ends with one "N passed, N failed" line.
test: tests
	$(Q)CONFIG=$(CONFIG) sh tests/run_tests.sh $(BUILD)

# Quick subset (no downloaded meshes).
check: tests
	$(Q)CLVOX_QUICK=1 CONFIG=$(CONFIG) sh tests/run_tests.sh $(BUILD)

# libFuzzer targets (tests/fuzz/fuzz_*.c), built with clang over the library
# sources (instrumented) and run briefly on their seed corpora
# (tests/fuzz/seeds_<name>/) and past findings (tests/fuzz/regress_<name>/);
# the corpus grows in build/fuzz/corpus_<name>/. `make test` replays seeds
# and findings without libFuzzer (tests/test_fuzz_smoke.c).
#   make fuzz                    build them
#   make fuzz-run FUZZ_SECONDS=60   build and run each, one after another, for FUZZ_SECONDS
#   make fuzz-run FUZZ_ONLY="mesh_obj mesh_ply"   only these targets
FUZZ_CC ?= clang
FUZZ_CXX ?= clang++
FUZZ_SECONDS ?= 30
FUZZ_ONLY ?=
FUZZ_FLAGS := -g -O1 -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
FUZZ_DIR := build/fuzz
FUZZ_SRCS := $(if $(FUZZ_ONLY),$(FUZZ_ONLY:%=tests/fuzz/fuzz_%.c),$(wildcard tests/fuzz/fuzz_*.c))
FUZZ_BINS := $(FUZZ_SRCS:tests/fuzz/%.c=$(FUZZ_DIR)/%)
FUZZ_LIB_OBJ := $(LIB_C:%.c=$(FUZZ_DIR)/%.o) $(LIB_CXX:%.cpp=$(FUZZ_DIR)/%.o) $(FUZZ_DIR)/gen/kernels_embedded.o

$(FUZZ_DIR)/%.o: %.c
	@mkdir -p $(dir $@)
	$(Q)$(FUZZ_CC) $(BASE_CFLAGS) $(if $(filter src/cli/%,$<),,-Isrc) $(FUZZ_FLAGS) -MMD -MP -c $< -o $@

$(FUZZ_DIR)/%.o: %.cpp
	@mkdir -p $(dir $@)
	$(Q)$(FUZZ_CXX) $(BASE_CXXFLAGS) $(FUZZ_FLAGS) -MMD -MP -c $< -o $@

$(FUZZ_DIR)/gen/kernels_embedded.o: $(KERNEL_C)
	@mkdir -p $(dir $@)
	$(Q)$(FUZZ_CC) -std=c11 -fPIC -O1 -c $< -o $@

# Targets of CLI code link the CLI files they need (FUZZ_CLI_<name>).
FUZZ_CLI_manifest := $(MANIFEST_CLI_SRC:%.c=$(FUZZ_DIR)/%.o)
$(FUZZ_DIR)/fuzz_manifest: $(FUZZ_CLI_manifest)

$(FUZZ_DIR)/fuzz_%: tests/fuzz/fuzz_%.c $(wildcard tests/fuzz/*.h) $(FUZZ_LIB_OBJ)
	$(Q)$(FUZZ_CC) $(BASE_CFLAGS) -Isrc $(FUZZ_FLAGS) -c $< -o $@.o
	$(Q)$(FUZZ_CXX) -fsanitize=fuzzer,address,undefined -o $@ $@.o $(FUZZ_CLI_$*) $(FUZZ_LIB_OBJ) $(LIBS)

fuzz: $(FUZZ_BINS)
.SECONDARY: $(FUZZ_LIB_OBJ) $(FUZZ_CLI_manifest)

fuzz-run: fuzz
	$(Q)for b in $(FUZZ_BINS); do n=$${b##*/fuzz_}; mkdir -p $(FUZZ_DIR)/corpus_$$n; \
	  $$b -max_total_time=$(FUZZ_SECONDS) -rss_limit_mb=2048 -timeout=10 $(FUZZ_DIR)/corpus_$$n tests/fuzz/seeds_$$n \
	  $$(test -d tests/fuzz/regress_$$n && echo tests/fuzz/regress_$$n) || exit 1; done

bench: all
	$(Q)sh scripts/bench/bench.sh

# The benchmarks' C helpers (scripts/bench/*.c), against this configuration's
# library, into build/<config>/bench/. The scripts in scripts/bench/ run
# `make -s bench-tools` themselves (scripts/bench/README.md).
#   make bench-tools
#   make bench-prep-base BENCH_BASE_TREE=DIR   bench_winding_prep(_borrow)
#        against another tree's build/release (scripts/bench/bench_winding_closed.sh --prep)
BENCH_BUILD := $(BUILD)/bench
BENCH_TOOLS := subdivide volume_diff volume_raw bench_load bench_writer bench_winding_oracle \
  bench_winding_prep bench_winding_prep_borrow bench_far_field
BENCH_BINS := $(BENCH_TOOLS:%=$(BENCH_BUILD)/%)
# -ffp-contract=off: the oracle's crossing arithmetic must be the library's, operation for operation.
BENCH_CFLAGS := -std=c11 -D_POSIX_C_SOURCE=200809L $(OPT) -ffp-contract=off -Wall -Wextra -Iinclude -Isrc -Ikernels $(CFLAGS)
bench-tools: $(BENCH_BINS)

$(BENCH_BUILD)/subdivide: scripts/bench/subdivide.c
	@mkdir -p $(dir $@)
	@$(if $(filter 0,$(V)),echo "  BENCH $@")
	$(Q)$(CC) $(BENCH_CFLAGS) $(FINAL_LDFLAGS) -o $@ $< -lm

$(BENCH_BUILD)/bench_winding_oracle: scripts/bench/bench_winding_oracle.c tests/reference.c tests/meshgen.c $(STATIC_LIB)
	@mkdir -p $(dir $@)
	@$(if $(filter 0,$(V)),echo "  BENCH $@")
	$(Q)$(CC) $(BENCH_CFLAGS) -Itests $(FINAL_LDFLAGS) -o $@ $(filter %.c,$^) $(STATIC_LIB) $(LIBS)

$(BENCH_BUILD)/bench_winding_prep_borrow: scripts/bench/bench_winding_prep.c $(STATIC_LIB)
	@mkdir -p $(dir $@)
	@$(if $(filter 0,$(V)),echo "  BENCH $@")
	$(Q)$(CC) $(BENCH_CFLAGS) -DCLVOX_BENCH_BORROW $(FINAL_LDFLAGS) -o $@ $< $(STATIC_LIB) $(LIBS)

$(BENCH_BUILD)/%: scripts/bench/%.c $(STATIC_LIB)
	@mkdir -p $(dir $@)
	@$(if $(filter 0,$(V)),echo "  BENCH $@")
	$(Q)$(CC) $(BENCH_CFLAGS) $(FINAL_LDFLAGS) -o $@ $< $(STATIC_LIB) $(LIBS)

# Always rebuilt: the other tree may have changed. Its link flags are the ones
# its build wrote (build/release/libclvox.libs), else this tree's.
BENCH_BASE_TREE ?=
bench-prep-base:
	$(if $(BENCH_BASE_TREE),,$(error make bench-prep-base needs BENCH_BASE_TREE=DIR))
	@mkdir -p $(BENCH_BUILD)
	$(Q)libs=$$(cat $(BENCH_BASE_TREE)/build/release/libclvox.libs 2>/dev/null || echo '$(LIBS)'); \
	for v in "" _borrow; do \
	  $(CC) $(subst -Iinclude -Isrc,-I$(BENCH_BASE_TREE)/include -I$(BENCH_BASE_TREE)/src,$(BENCH_CFLAGS)) \
	    $$( [ "$$v" = _borrow ] && echo -DCLVOX_BENCH_BORROW) $(FINAL_LDFLAGS) -o $(BENCH_BUILD)/bench_winding_prep_base$$v \
	    scripts/bench/bench_winding_prep.c $(BENCH_BASE_TREE)/build/release/libclvox.a $$libs -ldl || exit 1; \
	done

VERSION := $(shell sed -n 's/.*CLVOX_VERSION_STRING "\(.*\)"/\1/p' include/clvox.h)
install: all
	install -d $(DESTDIR)$(PREFIX)/include $(DESTDIR)$(PREFIX)/lib/pkgconfig $(DESTDIR)$(PREFIX)/bin \
	  $(DESTDIR)$(PREFIX)/share/clvox
	install -m 644 tests/data/default.obj $(DESTDIR)$(PREFIX)/share/clvox/default.obj
	install -m 644 include/clvox.h $(DESTDIR)$(PREFIX)/include/clvox.h
	install -m 644 $(STATIC_LIB) $(DESTDIR)$(PREFIX)/lib/libclvox.a
	install -m 755 $(SHARED_LIB) $(DESTDIR)$(PREFIX)/lib/libclvox.so.$(VERSION)
	ln -sf libclvox.so.$(VERSION) $(DESTDIR)$(PREFIX)/lib/libclvox.so.$(word 1,$(subst ., ,$(VERSION)))
	ln -sf libclvox.so.$(VERSION) $(DESTDIR)$(PREFIX)/lib/libclvox.so
	install -m 755 $(CLI_BIN) $(DESTDIR)$(PREFIX)/bin/clvox
	$(if $(VDB_PLUGIN),install -d $(DESTDIR)$(PREFIX)/lib/clvox && install -m 755 $(VDB_PLUGIN) $(DESTDIR)$(PREFIX)/lib/clvox/libclvox-vdb.so)
	sed -e 's|@PREFIX@|$(PREFIX)|g' -e 's|@VERSION@|$(VERSION)|g' -e 's|@LIBS_PRIVATE@|$(LIBS)|g' scripts/clvox.pc.in > $(DESTDIR)$(PREFIX)/lib/pkgconfig/clvox.pc

uninstall:
	rm -f $(DESTDIR)$(PREFIX)/include/clvox.h $(DESTDIR)$(PREFIX)/lib/libclvox.a \
	  $(DESTDIR)$(PREFIX)/lib/libclvox.so* $(DESTDIR)$(PREFIX)/bin/clvox \
	  $(DESTDIR)$(PREFIX)/lib/pkgconfig/clvox.pc
	rm -rf $(DESTDIR)$(PREFIX)/share/clvox $(DESTDIR)$(PREFIX)/lib/clvox

clean:
	rm -rf build

-include $(DEPS) $(FUZZ_LIB_OBJ:.o=.d) $(FUZZ_CLI_manifest:.o=.d)
