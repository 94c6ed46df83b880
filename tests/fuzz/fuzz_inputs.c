/* fuzz_inputs.c: the libFuzzer entry over the file readers and writers besides glTF (clang -fsanitize=fuzzer,address,undefined): each input through pm_fuzz_inputs_run. */
#include "fuzz_inputs_entry.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    pm_fuzz_inputs_run(data, size);
    return 0;
}
