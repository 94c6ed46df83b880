/* fuzz_target.c: the libFuzzer entry (clang -fsanitize=fuzzer,address,undefined): each input through pm_fuzz_run. */
#include "fuzz_entry.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    pm_fuzz_run(data, size);
    return 0;
}
