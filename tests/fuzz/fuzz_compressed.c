/* fuzz_compressed.c: the libFuzzer entry over the compressed-geometry decoders (clang -fsanitize=fuzzer,address,undefined): each input through pm_fuzz_compressed_run. */
#include "fuzz_compressed_entry.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    pm_fuzz_compressed_run(data, size);
    return 0;
}
