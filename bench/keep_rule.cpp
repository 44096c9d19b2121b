// The sparse grid's schedule against the dense grid (issue 11, item 2; named for the keep rule,
// which SDF levels followed before 0.11's surface following): per SDF file and resolution, the sparse
// coarse-to-fine extraction of the CPU path (its evaluations, active cells and triangles) beside
// marching cubes' sign changes over every cell of the dense (r+1)^3 grid. The sparse mesh is the
// dense one exactly when both find the same active cells and triangles: a cell the schedule
// dropped that the surface crosses shows as fewer. Prints a markdown table; exits 1 on a loss.
//   keep_rule [--resolutions 128,256,512] FILE.nfc...
// It calls libnfdecode's internals, not its C API: the dense grid must be evaluated at the very f32
// unit-frame points the sparse grid evaluates (the API takes original-frame points, whose round
// trip moves a point by an ulp, and flips the sign of corners within ~1e-7 of the surface).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "bitstream.h"
#include "extract.h"
#include "grid.h"
#include "mc_tables.h"
#include "network.h"
#include "stream.h"

namespace {

using namespace nfd;

std::vector<uint8_t> read_file(const char* path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        std::fprintf(stderr, "keep_rule: cannot open %s\n", path);
        std::exit(2);
    }
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Counts {
    uint64_t active = 0, triangles = 0;
};

// Marching cubes' cases over every cell of the dense grid, one z-layer of vertices at a time.
Counts dense_counts(const Network& net, uint32_t r) {
    const size_t side = size_t(r) + 1, layer = side * side;
    const float step = 2.0f / float(r);
    std::vector<float> below(layer), above(layer), points(3 * layer);
    auto evaluate_layer = [&](uint32_t z, std::vector<float>& out) {
        for (size_t i = 0; i < layer; ++i) {
            points[3 * i + 0] = -1.0f + float(i % side) * step;
            points[3 * i + 1] = -1.0f + float(i / side) * step;
            points[3 * i + 2] = -1.0f + float(z) * step;
        }
        evaluate_cpu(net, points.data(), layer, out.data());
    };
    Counts c;
    evaluate_layer(0, below);
    for (uint32_t z = 0; z < r; ++z) {
        evaluate_layer(z + 1, above);
        for (uint32_t y = 0; y < r; ++y)
            for (uint32_t x = 0; x < r; ++x) {
                int index = 0;
                for (int k = 0; k < 8; ++k) {
                    const uint8_t* o = mc::kCornerOffset[k];
                    const std::vector<float>& v = o[2] ? above : below;
                    index |= int(v[(y + o[1]) * side + x + o[0]] < 0) << k;
                }
                c.active += index != 0 && index != 255;
                c.triangles += mc::tables().triangle_count[index];
            }
        below.swap(above);
    }
    return c;
}

std::vector<uint32_t> parse_resolutions(const char* list) {
    std::vector<uint32_t> out;
    for (const char* p = list; *p;) {
        char* end = nullptr;
        const unsigned long r = std::strtoul(p, &end, 10);
        if (end == p || r < NFD_MIN_RESOLUTION || r > NFD_MAX_RESOLUTION) return {};
        out.push_back(uint32_t(r));
        p = *end == ',' ? end + 1 : end;
    }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    std::vector<uint32_t> resolutions = {128, 256, 512};
    std::vector<const char*> files;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--resolutions") && i + 1 < argc) resolutions = parse_resolutions(argv[++i]);
        else files.push_back(argv[i]);
    }
    if (files.empty() || resolutions.empty()) {
        std::fprintf(stderr, "usage: keep_rule [--resolutions 128,256,512] FILE.nfc...\n");
        return 2;
    }
    std::printf("| file | res | evaluations | per active cell | %% of dense | active cells | dense | "
                "triangles | dense | verdict |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n");
    bool lost = false;
    for (const char* path : files) {
        const std::vector<uint8_t> bytes = read_file(path);
        ParsedFile file;
        if (parse_file(bytes.data(), bytes.size(), &file) != NFD_SUCCESS) {
            std::fprintf(stderr, "keep_rule: %s does not parse\n", path);
            return 2;
        }
        if (file.geometry.field != FieldType::Sdf) {
            std::fprintf(stderr, "keep_rule: %s is not an SDF (a UDF has no sign changes to count)\n", path);
            return 2;
        }
        const char* name = std::strrchr(path, '/') ? std::strrchr(path, '/') + 1 : path;
        for (uint32_t r : resolutions) {
            MeshData mesh;
            ExtractStats stats;
            if (extract_mesh_cpu(file.geometry, r, &mesh, &stats) != NFD_SUCCESS) {
                std::fprintf(stderr, "keep_rule: %s at %u does not decode\n", path, r);
                return 2;
            }
            const Counts dense = dense_counts(file.geometry.network, r);
            const bool same = stats.active_cells == dense.active && mesh.triangle_count() == dense.triangles;
            lost |= !same;
            const double points = double(r + 1) * (r + 1) * (r + 1);
            std::printf("| %s | %u | %llu | %.2f | %.2f | %llu | %llu | %zu | %llu | %s |\n", name, r,
                        (unsigned long long)stats.points_evaluated,
                        double(stats.points_evaluated) / double(std::max<uint64_t>(stats.active_cells, 1)),
                        100.0 * double(stats.points_evaluated) / points, (unsigned long long)stats.active_cells,
                        (unsigned long long)dense.active, mesh.triangle_count(),
                        (unsigned long long)dense.triangles, same ? "same mesh" : "**cells lost**");
            std::fflush(stdout);
        }
    }
    return lost ? 1 : 0;
}
