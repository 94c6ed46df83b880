# Makefile: builds pmview, its tests (under ASan/UBSan and TSan) and benchmarks; installs missing Debian packages first.
#
#   make          build ./pmview                 make run    install, build, render the default scene
#   make test     install, build, run all tests  make bench  speed figures (ratios measured in one run), written to docs/benchmarks.md
#                 (JOBS=N: N tests side by side, 2 by default)
#   make check    the whole suite under ASan+UBSan, the threaded tests under TSan, a render under valgrind
#   make fuzz     libFuzzer (clang): glTF through load, set-up, accel and a tiny render, then the sky, reference
#                 and writers' inputs, then the compressed-mesh decoders, FUZZ_SECONDS (600) each
#   make convergence  error against time for each method on the reference scenes at 64x64 and 128x128: docs/convergence.md (QUICK=1: a short one)
#   make clean

CC      ?= cc
CXX     ?= c++
OPT     ?= -O2
# Open MPI's headers and library: only src/cluster.c uses them, built alone as the module
# pmview-cluster.so that pmview opens (dlopen) next to itself when an MPI launcher started it
MPI_CFLAGS = $(shell pkg-config --cflags ompi-c 2>/dev/null || echo -I/usr/lib/x86_64-linux-gnu/openmpi/include)
MPI_LIBS   = $(shell pkg-config --libs ompi-c 2>/dev/null || echo -lmpi)
CFLAGS_COMMON = -g -fno-math-errno -Wall -Wextra -Wno-unused-parameter -pthread -Iinclude -Ibuild -I/usr/include/OpenEXR
CFLAGS   = -std=c11 $(OPT) $(CFLAGS_COMMON) -D_POSIX_C_SOURCE=200809L
# The C++ units carry line tables and function names (-g1: enough for every sanitizer report and
# backtrace) but not the full debug information of their template-heavy code (tinygltf, nlohmann's
# JSON, Draco), whose generation took a third of the loader's compile time in each build tree.
CXXFLAGS = -std=c++14 $(OPT) -g1 -Wall -pthread -Iinclude -I/usr/include/stb
LIBS     = -lembree3 -lglfw -lX11 -lOpenEXRCore-3_1 -lstb -ldraco -lmeshoptimizer -lstdc++ -lm -pthread
# pmview's own functions the MPI module calls (the film, the session, the memory accounting)
EXPORT_TO_MODULE = -Wl,--export-dynamic-symbol=pm_*

C_SRC   := $(filter-out src/main.c src/cluster.c,$(wildcard src/*.c))
CXX_SRC := $(wildcard src/*.cpp)
TESTS   := $(patsubst tests/%.c,%,$(wildcard tests/test_*.c))
SCENE   ?= scenes/cornell-box.gltf
TSAN_TESTS := test_threads test_texture_threads
# the tests run_tests.sh runs from the optimised build (its OPTIMISED list); every other test runs from the ASan build
OPTIMISED_TESTS := $(shell sed -n 's/^OPTIMISED="\(.*\)"$$/\1/p' tests/run_tests.sh)
# tests run side by side by `make test` (run_tests.sh's JOBS)
JOBS ?= 2
# Every compile writes the headers it read to a .d file beside its output (-MMD), with an empty rule for
# each header (-MP) so a deleted header does not stop the build; the .d files are included at the end.
DEPFLAGS := -MMD -MP

.PHONY: all deps run test check bench convergence clean tests-build fuzz fuzz-deps
all: pmview

deps:
	@sh tools/install-deps.sh

# The display shaders are compiled into the binary so pmview runs from any folder.
build/shaders.inc: $(wildcard shaders/*)
	@mkdir -p build
	@for f in $(wildcard shaders/*); do n=$$(basename $$f | tr '.-' '__'); \
	  printf 'static const char pm_shader_%s[] =\n' "$$n"; \
	  sed 's/\\/\\\\/g; s/"/\\"/g; s/^/"/; s/$$/\\n"/' $$f; printf ';\n'; done > $@

# variant objects: build/<variant>/name.o; $(3), when given, is the C++ units' optimisation level, $(4) the test
# programs' own.
# A test program is compiled on its own (its .o) and then linked, so the compiles need not wait for the library.
define variant
build/$(1)/%.o: src/%.c | build/shaders.inc
	@mkdir -p build/$(1)
	$$(CC) $$(CFLAGS) $(DEPFLAGS) $(2) -c $$< -o $$@
build/$(1)/%.o: src/%.cpp
	@mkdir -p build/$(1)
	$$(CXX) $$(CXXFLAGS) $(3) $(DEPFLAGS) $(2) -c $$< -o $$@
build/$(1)/tests/%.o: tests/%.c | build/shaders.inc
	@mkdir -p build/$(1)/tests
	$$(CC) $$(CFLAGS) $(4) $(DEPFLAGS) $(2) -Itests -c $$< -o $$@
build/$(1)/tests/%: build/$(1)/tests/%.o build/$(1)/libpm.a
	$$(CC) $$< build/$(1)/libpm.a -o $$@ $(2) -pthread $$(LIBS)
build/$(1)/pic/cluster.o: src/cluster.c
	@mkdir -p build/$(1)/pic
	$$(CC) $$(CFLAGS) $$(MPI_CFLAGS) $(DEPFLAGS) $(2) -fPIC -fvisibility=hidden -c $$< -o $$@
build/$(1)/pmview-cluster.so: build/$(1)/pic/cluster.o
	$$(CC) -shared $$< -o $$@ $(2) $$(MPI_LIBS)
build/$(1)/libpm.a: $(patsubst src/%.cpp,build/$(1)/%.o,$(CXX_SRC)) $(patsubst src/%.c,build/$(1)/%.o,$(C_SRC))
	@rm -f $$@
	ar rcs $$@ $$^
endef
$(eval $(call variant,rel,))
comma := ,
ASAN_FLAGS := -fsanitize=address$(comma)undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
# The C++ units (the glTF loader: tinygltf and its JSON templates) take most of the ASan build's time at -O2;
# at -Og they compile in about a quarter of it (28 s against 105 s of processor time, measured on a loaded
# machine), with the same ASan+UBSan instrumentation.
ASAN_CXX_OPT := -Og
# The ASan build's test programs spend their time in the library, not in their own code: at -O1 they
# compile in 37 s of processor time against 59 s at -O2 and run in the same 91 s.
ASAN_TEST_OPT := -O1
$(eval $(call variant,asan,$(ASAN_FLAGS),$(ASAN_CXX_OPT),$(ASAN_TEST_OPT)))
$(eval $(call variant,tsan,-fsanitize=thread))

pmview: build/rel/main.o build/rel/libpm.a pmview-cluster.so
	$(CC) $(CFLAGS) build/rel/main.o build/rel/libpm.a -o $@ $(LIBS) $(EXPORT_TO_MODULE)

pmview-cluster.so: build/rel/pmview-cluster.so
	cp $< $@

run: deps pmview
	@sh tools/run-default.sh $(SCENE)

# what `make test` runs: the ASan build of every test program but the few that run optimised, their optimised
# build, and the two pmview builds the script tests drive
# The C++ objects come first: with -j2 the ASan loader, the longest compile, starts at once and the rest
# of the build runs beside it.
tests-build: $(patsubst src/%.cpp,build/asan/%.o,$(CXX_SRC)) $(patsubst src/%.cpp,build/rel/%.o,$(CXX_SRC)) \
             pmview build/rel/error_map build/asan/pmview $(addprefix build/asan/tests/,$(filter-out $(OPTIMISED_TESTS),$(TESTS))) \
             $(addprefix build/rel/tests/,$(OPTIMISED_TESTS))

build/asan/pmview: build/asan/main.o build/asan/libpm.a build/asan/pmview-cluster.so
	$(CC) $(CFLAGS) $(ASAN_FLAGS) build/asan/main.o build/asan/libpm.a -o $@ $(LIBS) $(ASAN_FLAGS) $(EXPORT_TO_MODULE)

test: deps
	@start=$$(date +%s); $(MAKE) --no-print-directory -j2 tests-build && echo "make test: built in $$(( $$(date +%s) - start )) s"
	@JOBS=$(JOBS) sh tests/run_tests.sh

# everything under ASan+UBSan (the optimised tests too), the threaded tests under TSan, a render under valgrind
check:
	@sh tools/install-deps.sh check
	@$(MAKE) --no-print-directory -j2 tests-build $(addprefix build/asan/tests/,$(OPTIMISED_TESTS)) $(addprefix build/tsan/tests/,$(TSAN_TESTS))
	@PMVIEW_CHECK=1 JOBS=$(JOBS) sh tests/run_tests.sh

# The fuzz target: clang's libFuzzer over the whole library, built with its own compiler and flags.
FUZZ_CC      ?= clang
FUZZ_CXX     ?= clang++
FUZZ_SECONDS ?= 600
FUZZ_SAN     := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
build/fuzz/%.o: src/%.c | build/shaders.inc
	@mkdir -p build/fuzz
	$(FUZZ_CC) $(CFLAGS) $(DEPFLAGS) $(FUZZ_SAN) -fsanitize=fuzzer-no-link -c $< -o $@
build/fuzz/%.o: src/%.cpp
	@mkdir -p build/fuzz
	$(FUZZ_CXX) $(CXXFLAGS) $(DEPFLAGS) $(FUZZ_SAN) -fsanitize=fuzzer-no-link -c $< -o $@
build/fuzz/libpm.a: $(patsubst src/%.c,build/fuzz/%.o,$(C_SRC)) $(patsubst src/%.cpp,build/fuzz/%.o,$(CXX_SRC))
	@rm -f $@
	ar rcs $@ $^
build/fuzz/fuzz_gltf: tests/fuzz/fuzz_target.c build/fuzz/libpm.a
	$(FUZZ_CC) $(CFLAGS) $(DEPFLAGS) $(FUZZ_SAN) -fsanitize=fuzzer -Itests/fuzz -MT $@ -c $< -o build/fuzz/fuzz_target.o
	$(FUZZ_CXX) $(FUZZ_SAN) -fsanitize=fuzzer build/fuzz/fuzz_target.o build/fuzz/libpm.a -o $@ $(LIBS)

fuzz-deps:
	@sh tools/install-deps.sh fuzz

build/fuzz/fuzz_inputs: tests/fuzz/fuzz_inputs.c build/fuzz/libpm.a
	$(FUZZ_CC) $(CFLAGS) $(DEPFLAGS) $(FUZZ_SAN) -fsanitize=fuzzer -Itests/fuzz -MT $@ -c $< -o build/fuzz/fuzz_inputs.o
	$(FUZZ_CXX) $(FUZZ_SAN) -fsanitize=fuzzer build/fuzz/fuzz_inputs.o build/fuzz/libpm.a -o $@ $(LIBS)

build/fuzz/fuzz_compressed: tests/fuzz/fuzz_compressed.c tests/fuzz/fuzz_compressed_entry.h build/fuzz/libpm.a
	$(FUZZ_CC) $(CFLAGS) $(FUZZ_SAN) -fsanitize=fuzzer -Itests/fuzz -c $< -o build/fuzz/fuzz_compressed.o
	$(FUZZ_CXX) $(FUZZ_SAN) -fsanitize=fuzzer build/fuzz/fuzz_compressed.o build/fuzz/libpm.a -o $@ $(LIBS)

fuzz: fuzz-deps
	@$(MAKE) --no-print-directory build/fuzz/fuzz_gltf build/fuzz/fuzz_inputs build/fuzz/fuzz_compressed
	@sh tools/run-fuzz.sh $(FUZZ_SECONDS)

bench: deps pmview build/rel/bench_pm build/rel/photon_ceiling build/rel/caustic_error build/rel/texture_footprint build/rel/json_load
	@sh bench/run_bench.sh

build/rel/bench_pm: bench/bench_pm.c build/rel/libpm.a
	$(CC) $(CFLAGS) $(DEPFLAGS) $< build/rel/libpm.a -o $@ $(LIBS)

# The photon pass's own rays are recorded by wrapping pm_accel_intersect and pm_accel_intersect_packets at link time, for this program only.
build/rel/photon_ceiling: bench/photon_ceiling.c build/rel/libpm.a
	$(CC) $(CFLAGS) $(DEPFLAGS) $< build/rel/libpm.a -o $@ -Wl,--wrap=pm_accel_intersect -Wl,--wrap=pm_accel_intersect_packets $(LIBS)

build/rel/texture_footprint: bench/texture_footprint.c build/rel/libpm.a
	$(CC) $(CFLAGS) $(DEPFLAGS) -Itests $< build/rel/libpm.a -o $@ $(LIBS)

build/rel/json_load: bench/json_load.c build/rel/libpm.a
	$(CC) $(CFLAGS) $(DEPFLAGS) $< build/rel/libpm.a -o $@ $(LIBS)

build/rel/caustic_error: bench/caustic_error.c build/rel/libpm.a
	$(CC) $(CFLAGS) $(DEPFLAGS) -Itests $< build/rel/libpm.a -o $@ $(LIBS)

# Takes about 26 minutes (60 runs of 24 s, one at a time; CONV_METHODS=all: every method); QUICK=1 about 2 minutes. gnuplot draws the plots.
convergence: deps pmview build/rel/error_map
	@sh tools/install-deps.sh convergence
	@QUICK=$(QUICK) sh tools/convergence.sh

build/rel/error_map: tools/error_map.c build/rel/libpm.a
	$(CC) $(CFLAGS) $(DEPFLAGS) $< build/rel/libpm.a -o $@ $(LIBS)

clean:
	rm -rf build pmview pmview-cluster.so

# the headers each object, test and tool was built from, as the compiler found them
-include $(wildcard build/*/*.d build/*/tests/*.d build/*/pic/*.d)
# the test programs' objects are kept after their link, so a relink does not compile them again
.SECONDARY:
