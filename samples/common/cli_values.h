// Command-line values shared by the samples (nfc-decode, nfc-viewer): transfer rates and lists of
// progressive levels. Each parser returns an empty value and sets *error (the whole message the
// sample prints) when the text is not valid; the samples decide how to fail.
#pragma once

#include <nfdecode/nfdecode.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

namespace nfc_cli {

// "256KB/s": a positive number, then B/s, KB/s or MB/s with 1 KB = 1024 B. Bytes per second;
// 0 and *error on anything else.
inline double parse_bandwidth(const char* text, std::string* error) {
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(text, &end);
    const std::string unit = end;
    const double scale = unit == "B/s" ? 1.0 : unit == "KB/s" ? 1024.0 : unit == "MB/s" ? 1048576.0 : 0;
    if (end == text || errno || !std::isfinite(v) || !(v > 0) || scale == 0) {
        *error = std::string("--bandwidth expects a rate such as 256KB/s (B/s, KB/s or MB/s, "
                             "1 KB = 1024 B), got '") + text + "'";
        return 0;
    }
    return v * scale;
}

// "32,64,128,256": ascending resolutions, each a level of the last one's ladder
// (nfd_extraction_ladder). Empty and *error when not.
inline std::vector<uint32_t> parse_levels(const char* text, std::string* error) {
    std::vector<uint32_t> levels;
    const std::string list = text;
    for (size_t begin = 0; begin <= list.size();) {
        const size_t comma = std::min(list.find(',', begin), list.size());
        const std::string item = list.substr(begin, comma - begin);
        char* end = nullptr;
        errno = 0;
        const unsigned long v = std::strtoul(item.c_str(), &end, 10);
        if (item.empty() || *end || errno || item[0] == '-' || v < NFD_MIN_RESOLUTION ||
            v > NFD_MAX_RESOLUTION) {
            *error = "--levels expects resolutions in " + std::to_string(NFD_MIN_RESOLUTION) +
                     ".." + std::to_string(NFD_MAX_RESOLUTION) + ", got '" + item + "'";
            return {};
        }
        levels.push_back(uint32_t(v));
        if (levels.size() > 1 && levels.back() <= levels[levels.size() - 2]) {
            *error = "--levels must be ascending, got '" + list + "'";
            return {};
        }
        begin = comma + 1;
    }
    uint32_t ladder[NFD_MAX_LADDER_LEVELS], count = 0;
    const nfd_result r = nfd_extraction_ladder(levels.back(), ladder, NFD_MAX_LADDER_LEVELS, &count);
    if (r != NFD_SUCCESS) {
        *error = std::string("--levels: ") + nfd_result_string(r);
        return {};
    }
    std::string rungs;
    for (uint32_t i = 0; i < count; ++i) rungs += (i ? "," : "") + std::to_string(ladder[i]);
    for (uint32_t level : levels)
        if (std::find(ladder, ladder + count, level) == ladder + count) {
            *error = "--levels: " + std::to_string(level) + " is not a level of " +
                     std::to_string(levels.back()) + " (its levels: " + rungs + ")";
            return {};
        }
    return levels;
}

// The ladder mask (nfd_job_options.mesh_levels, nfd_extraction_options.mesh_levels) of levels
// that parse_levels accepted: bit i for ladder level i of the last one's ladder.
inline uint32_t ladder_mask(const std::vector<uint32_t>& levels) {
    uint32_t ladder[NFD_MAX_LADDER_LEVELS], count = 0, mask = 0;
    if (levels.empty() ||
        nfd_extraction_ladder(levels.back(), ladder, NFD_MAX_LADDER_LEVELS, &count) != NFD_SUCCESS)
        return 0;
    for (uint32_t i = 0; i < count; ++i)
        if (std::find(levels.begin(), levels.end(), ladder[i]) != levels.end()) mask |= 1u << i;
    return mask;
}

}  // namespace nfc_cli
