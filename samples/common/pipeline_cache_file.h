// A libnfdecode pipeline cache kept in a file between runs (nfd_context_get_pipeline_cache,
// nfd_context_options.pipeline_cache), shared by the samples. The library checks the bytes it is
// given, so a missing, stale or damaged file needs no care here: it is read as it is.
#pragma once
#include <nfdecode/nfdecode.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>
#include <vector>

namespace nfc_cli {

// $XDG_CACHE_HOME/nfc/pipelines.bin, else $HOME/.cache/nfc/pipelines.bin; "" with neither.
inline std::string default_pipeline_cache_path() {
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
        return std::string(xdg) + "/nfc/pipelines.bin";
    if (const char* home = std::getenv("HOME"); home && *home)
        return std::string(home) + "/.cache/nfc/pipelines.bin";
    return "";
}

// The file's bytes; none when it is missing, unreadable or past the library's 256 MiB cap.
inline std::vector<unsigned char> read_pipeline_cache(const std::string& path) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    if (path.empty() || ec || size > (uintmax_t(256) << 20)) return {};
    std::ifstream in(path, std::ios::binary);
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                     std::istreambuf_iterator<char>());
    return in.bad() ? std::vector<unsigned char>() : bytes;
}

// Saves the context's pipeline cache to `path`, replacing the file whole: written beside it,
// then renamed (a concurrent run reads the old file or the new one), its directory created.
// Nothing is written for a context without a cache (the CPU path). "" on success, else why not.
inline std::string save_pipeline_cache(const nfd_context* context, const std::string& path) {
    std::vector<unsigned char> bytes;
    size_t size = 0;
    nfd_result r = nfd_context_get_pipeline_cache(context, nullptr, &size);
    // The cache may grow between the two calls (a compile on a thread of the context): again.
    for (int attempt = 0; r == NFD_SUCCESS && size > 0 && attempt < 4; ++attempt) {
        bytes.resize(size);
        r = nfd_context_get_pipeline_cache(context, bytes.data(), &size);
        if (r != NFD_ERROR_LIMIT_EXCEEDED) break;
        r = NFD_SUCCESS;
    }
    if (r != NFD_SUCCESS) return nfd_result_string(r);
    if (size == 0) return "";
    bytes.resize(size);
    std::error_code ec;
    const std::filesystem::path target(path);
    if (target.has_parent_path()) std::filesystem::create_directories(target.parent_path(), ec);
    const std::string temporary = path + ".tmp" + std::to_string(getpid());
    bool ok;
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
        out.close();
        ok = bool(out);
    }
    if (ok) std::filesystem::rename(temporary, target, ec);
    if (ok && !ec) return "";
    std::remove(temporary.c_str());
    return ok ? ec.message() : "cannot write " + temporary;
}

}  // namespace nfc_cli
