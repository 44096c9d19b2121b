// Generates the marching-cubes triangle table from first principles instead of typing in the
// classic 256-case table (whose ambiguous cases disagree across shared faces and leave holes).
//
// For one case, walk each cube face counter-clockwise as seen from outside the cube. Where the
// walk leaves the inside region (an "exit") and re-enters it (an "entry") the iso-contour crosses
// the face edge; joining each exit to the entry that closes the inside region it left keeps the
// inside region on the left of every segment. Every crossing edge borders two faces, which walk it
// in opposite directions, so it is an exit on one face and an entry on the other: the segments
// chain into closed loops around the inside region. Each loop is triangulated as a fan, reversed so
// that triangles face away from the inside.
#include "mc_tables.h"

#include <stdexcept>

namespace nfd::mc {
namespace {

int corner_at(int x, int y, int z) { return x | y << 1 | z << 2; }

int edge_between(int c0, int c1) {
    for (int e = 0; e < 12; ++e)
        if ((kEdgeCorners[e][0] == c0 && kEdgeCorners[e][1] == c1) ||
            (kEdgeCorners[e][0] == c1 && kEdgeCorners[e][1] == c0))
            return e;
    throw std::logic_error("corners do not share a cube edge");
}

// The four corners of each face, counter-clockwise seen from outside the cube.
struct Faces {
    int corners[6][4];
    Faces() {
        for (int axis = 0; axis < 3; ++axis) {
            const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // e_u x e_v = e_axis
            for (int side = 0; side < 2; ++side) {
                const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};  // CCW seen from +e_axis
                for (int k = 0; k < 4; ++k) {
                    int xyz[3];
                    xyz[axis] = side;
                    xyz[u] = uv[k][0];
                    xyz[v] = uv[k][1];
                    // Seen from -e_axis (side 0) the same cycle runs clockwise: reverse it.
                    corners[2 * axis + side][side ? k : 3 - k] = corner_at(xyz[0], xyz[1], xyz[2]);
                }
            }
        }
    }
};

// Whether cube edges a and b lie on a common face: they share a corner, or are opposite edges of
// one face (parallel, differing in exactly one of the two other coordinates).
bool share_face(int a, int b) {
    if (a / 4 == b / 4) return __builtin_popcount(unsigned(a % 4) ^ unsigned(b % 4)) == 1;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j)
            if (kEdgeCorners[a][i] == kEdgeCorners[b][j]) return true;
    return false;
}

// Triangulates loop[i..j] (i, j joined by a loop segment or an accepted diagonal). A diagonal may
// not join two crossings on a common cube face: the neighbouring cell could draw the same segment
// across that face, and the edge would then border four triangles (watertight, but not manifold).
// Only chords through the cube's interior are allowed, which no other cell can see.
bool triangulate(const int* loop, int i, int j, int (*out)[3], int* count) {
    if (j - i < 2) return true;
    for (int k = i + 1; k < j; ++k) {
        const bool left_ok = k == i + 1 || !share_face(loop[i], loop[k]);
        const bool right_ok = k == j - 1 || !share_face(loop[k], loop[j]);
        if (!left_ok || !right_ok) continue;
        const int saved = *count;
        out[*count][0] = loop[i], out[*count][1] = loop[k], out[*count][2] = loop[j];
        ++*count;
        if (triangulate(loop, i, k, out, count) && triangulate(loop, k, j, out, count)) return true;
        *count = saved;
    }
    return false;
}

void build_case(int index, const Faces& faces, Tables& t) {
    auto inside = [index](int c) { return (index >> c) & 1; };
    int next[12];  // next[exit edge] = entry edge that closes its segment; -1 = no crossing
    for (int& n : next) n = -1;

    for (const auto& q : faces.corners) {
        int crossings = 0;
        for (int k = 0; k < 4; ++k) crossings += inside(q[k]) != inside(q[(k + 1) % 4]);
        if (crossings == 0) continue;
        // For every inside corner that starts a run of inside corners along the walk, the entry
        // edge is the one leading into the run and the exit edge the one leaving it. With four
        // crossings (diagonal inside corners) each inside corner is its own run: the ambiguous face
        // is cut so that inside corners are separated, whichever cube looks at it.
        for (int k = 0; k < 4; ++k) {
            const int prev = q[(k + 3) % 4], here = q[k];
            if (!inside(here) || inside(prev)) continue;
            int last = k;
            while (inside(q[(last + 1) % 4])) last = (last + 1) % 4;
            const int entry = edge_between(prev, here);
            const int exit = edge_between(q[last], q[(last + 1) % 4]);
            next[exit] = entry;
        }
    }

    int count = 0;
    int8_t* out = t.triangles[index];
    bool visited[12] = {};
    for (int start = 0; start < 12; ++start) {
        if (next[start] < 0 || visited[start]) continue;
        int loop[12], n = 0;
        for (int e = start; !visited[e]; e = next[e]) {
            if (next[e] < 0) throw std::logic_error("open iso-contour loop");
            visited[e] = true;
            loop[n++] = e;
        }
        if (count + n - 2 > kMaxTrianglesPerCase) throw std::logic_error("too many triangles");
        int triangles[kMaxTrianglesPerCase][3];
        int made = 0;
        if (!triangulate(loop, 0, n - 1, triangles, &made))
            throw std::logic_error("no triangulation without face diagonals");
        // The loop runs counter-clockwise around the inside region seen from outside the cube, so
        // (v0, v1, v2) in loop order would face the inside: emit each triangle reversed.
        for (int k = 0; k < made; ++k) {
            out[3 * count + 0] = int8_t(triangles[k][0]);
            out[3 * count + 1] = int8_t(triangles[k][2]);
            out[3 * count + 2] = int8_t(triangles[k][1]);
            ++count;
        }
    }
    t.triangle_count[index] = uint8_t(count);
}

Tables generate() {
    Tables t;
    for (auto& row : t.triangles)
        for (int8_t& e : row) e = -1;
    const Faces faces;
    for (int index = 0; index < 256; ++index) build_case(index, faces, t);
    for (uint32_t& word : t.holds_triangle) word = 0;
    for (int index = 0; index < 256; ++index)
        for (int k = 0; k < t.triangle_count[index]; ++k) {
            const int8_t* e = &t.triangles[index][3 * k];
            const uint32_t triangle = 1u << e[0] | 1u << e[1] | 1u << e[2];
            const uint32_t others = 0xFFFu & ~triangle;
            for (uint32_t s = others;; s = (s - 1) & others) {  // every superset of the triangle
                const uint32_t m = triangle | s;
                t.holds_triangle[m / 32] |= 1u << (m % 32);
                if (s == 0) break;
            }
        }
    return t;
}

}  // namespace

const Tables& tables() {
    static const Tables t = generate();
    return t;
}

}  // namespace nfd::mc
