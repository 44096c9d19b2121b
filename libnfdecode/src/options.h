// Reading the public option structs by their struct_size (nfdecode.h, "Option structs"): what
// lets a field be appended without breaking programs built against an older header.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "nfdecode/nfdecode.h"

namespace nfd {

// Copies the caller's `in` (NULL = all defaults) into `out`, zero-filling (defaulting) the fields
// that its struct_size does not cover. `first_layout` is the size of the struct in the version
// that introduced struct_size, assumed when struct_size is 0. Larger structs (a newer header) are
// accepted when every byte this library does not know is zero, as Linux's copy_struct_from_user.
template <class Options>
nfd_result read_options(const Options* in, size_t first_layout, Options* out) {
    static_assert(offsetof(Options, struct_size) == 0, "struct_size comes first");
    *out = Options{};
    if (!in) return NFD_SUCCESS;
    const size_t size = in->struct_size ? in->struct_size : first_layout;
    if (size < first_layout) return NFD_ERROR_INVALID_ARGUMENT;
    const auto* bytes = reinterpret_cast<const unsigned char*>(in);
    for (size_t i = sizeof(Options); i < size; ++i)
        if (bytes[i] != 0) return NFD_ERROR_INVALID_ARGUMENT;
    std::memcpy(out, in, size < sizeof(Options) ? size : sizeof(Options));
    out->struct_size = uint32_t(sizeof(Options));
    return NFD_SUCCESS;
}

}  // namespace nfd
