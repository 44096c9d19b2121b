// libFuzzer entry point over the parser (the only code that reads untrusted bytes):
//   cmake -DNFD_BUILD_FUZZERS=ON -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ ...
//   ./tests/fuzz_asset corpus/
// Seed the corpus with tests/vectors/*.nfc.
#include <nfdecode/nfdecode.h>

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    nfd_asset* asset = nullptr;
    if (nfd_asset_create(data, size, &asset) == NFD_SUCCESS) {
        nfd_asset_info info;
        nfd_asset_get_info(asset, &info);
        nfd_asset_destroy(asset);
    }
    return 0;
}
