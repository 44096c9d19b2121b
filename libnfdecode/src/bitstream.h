// The .nfc reader (FORMAT.md): the only code in libnfdecode that looks at file bytes.
#pragma once
#include <cstddef>
#include <cstdint>

#include "network.h"
#include "nfdecode/nfdecode.h"

namespace nfd {

// CRC-32, ISO-HDLC / zlib: reflected polynomial 0xEDB88320, init and xorout 0xFFFFFFFF.
uint32_t crc32(const uint8_t* data, size_t size);

struct ParsedFile {
    uint32_t major = 0, minor = 0;  // minor may exceed NFD_FORMAT_MINOR (newer optional chunks)
    uint32_t file_size = 0;
    Geometry geometry;              // dequantized GEOM chunk
    bool has_colour = false;        // a `colr` chunk was present (verified, not decoded in 1.0)
};

// Verifies `size` bytes completely and dequantizes the geometry network. Checks run in the order
// FORMAT.md documents, so a given damage always yields the same result code:
//   NFD_ERROR_TRUNCATED            fewer bytes than the header or a structure needs
//   NFD_ERROR_CORRUPT              magic, CRC, value or cap violation, brotli failure, trailing data
//   NFD_ERROR_UNSUPPORTED_VERSION  major != 1
//   NFD_ERROR_UNSUPPORTED_FEATURE  unknown critical chunk
// Allocates only after the caps have bounded the sizes (at most ~6 MiB of levels and weights, plus
// brotli's own window of at most 16 MiB). May throw std::bad_alloc; api.cpp maps it.
nfd_result parse_file(const uint8_t* bytes, size_t size, ParsedFile* out);

}  // namespace nfd
