#include "sample_points.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace nfd {
namespace {

struct SplitMix64 {
    uint64_t state;
    uint64_t next() {
        uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
};

void cross(const double* a, const double* b, double* out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

// Twice the triangle's area vector (un-normalised face normal), in f64.
void face_normal(const MeshData& m, size_t t, double* n) {
    const float* p[3];
    for (int k = 0; k < 3; ++k) p[k] = &m.positions[3 * size_t(m.indices[3 * t + k])];
    double e1[3], e2[3];
    for (int a = 0; a < 3; ++a) {
        e1[a] = double(p[1][a]) - p[0][a];
        e2[a] = double(p[2][a]) - p[0][a];
    }
    cross(e1, e2, n);
}

}  // namespace

void sample_points(const MeshData& mesh, size_t count, uint64_t seed, float* points,
                   float* normals) {
    const size_t triangles = mesh.triangle_count();
    // Cumulative areas in f64: a million small triangles summed in f32 would skew the choice.
    nfd::vector<double> cumulative(triangles);
    double total = 0;
    for (size_t t = 0; t < triangles; ++t) {
        double n[3];
        face_normal(mesh, t, n);
        total += std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        cumulative[t] = total;
    }

    SplitMix64 rng{seed};
    for (size_t i = 0; i < count; ++i) {
        size_t t;
        if (total > 0) {
            const double target = rng.uniform() * total;
            t = size_t(std::upper_bound(cumulative.begin(), cumulative.end(), target) -
                       cumulative.begin());
            t = std::min(t, triangles - 1);
        } else {  // every triangle degenerate: area gives no preference
            t = size_t(rng.uniform() * double(triangles));
        }
        // Uniform barycentrics: sqrt maps the unit square onto the triangle without bias.
        const double s = std::sqrt(rng.uniform()), r = rng.uniform();
        const double w[3] = {1.0 - s, s * (1.0 - r), s * r};
        const uint32_t* tri = &mesh.indices[3 * t];
        for (int a = 0; a < 3; ++a) {
            double v = 0;
            for (int k = 0; k < 3; ++k) v += w[k] * mesh.positions[3 * size_t(tri[k]) + a];
            points[3 * i + a] = float(v);
        }
        if (!normals) continue;
        double n[3];
        face_normal(mesh, t, n);
        double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(len > 0)) {  // degenerate face: fall back to its vertices' normals
            for (int a = 0; a < 3; ++a) {
                n[a] = 0;
                for (int k = 0; k < 3; ++k) n[a] += mesh.normals[3 * size_t(tri[k]) + a];
            }
            len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        }
        for (int a = 0; a < 3; ++a) normals[3 * i + a] = len > 0 ? float(n[a] / len) : 0.0f;
    }
}

}  // namespace nfd
