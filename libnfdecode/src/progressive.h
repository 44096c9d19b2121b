// Progressive extraction (nfdecode.h, "Progressive extraction"): the grid's levels from the
// coarsest to the finest, one per step, each optionally meshed as if it were the finest level of a
// grid of its own, and each evaluating only the corners its parent level did not hold.
//
// Level l of a decode at resolution r has cells_at_level(r, l) cells of edge h = 2^l * 2 / r. When
// 2^l divides r, its cells, corner values and f32 vertex positions are those of the finest level of
// a one-shot decode at r / 2^l (the same schedule in h, the same refinement below it, and
// -1 + v * h equal to -1 + (v << l) * 2 / r: grid.h, GridLevel::coord), so its mesh is byte for
// byte that decode's, but for an SDF's cells that surface following above the finest level finds
// from cells and vertices near zero (grid.h, steps 1 and 2), which that decode's finest level
// does not look for (nfdecode.h, "The meshes"). When 2^l does not divide r (r = 130: levels 33, 65, 130) the level is no
// one-shot's finest level: its last cells reach past u = 1 (grid.h), and its mesh is marching cubes
// on exactly the cells and values the decode at r visits there, extending up to h past the cube.
#pragma once
#include <cstdint>
#include <memory>

#include "extract.h"

namespace nfd {

// What one step did, and what the next one will need.
struct LevelReport {
    uint32_t level = 0;           // grid level l (0 = finest)
    uint32_t cells_per_axis = 0;  // its resolution
    bool done = false;            // it was the finest
    bool meshed = false;          // the step's mesh was made
    uint64_t points_evaluated = 0, gradients_evaluated = 0;  // new in this step
    // Upper bounds of the bytes the next step allocates (0 when done): host, and device for the
    // GPU path.
    uint64_t next_host_bytes = 0, next_device_bytes = 0;
};

class Extraction {
public:
    virtual ~Extraction() = default;
    // Evaluates the next level, then meshes it when the mask given at creation has its bit
    // (bit l: grid level l): the mesh in the original frame, `stats` cumulative over the steps so
    // far (so the finest level's equal the one-shot decode's). Not after `done`.
    virtual nfd_result step(MeshData* mesh, ExtractStats* stats, LevelReport* report) = 0;
};

// The CPU path. `resolution` within the caps; `threads` as for evaluate_cpu; `band` as for
// GridBuilder. The geometry must outlive the extraction.
std::unique_ptr<Extraction> make_extraction_cpu(const Geometry& geometry, uint32_t resolution,
                                                uint32_t mesh_mask, unsigned threads,
                                                bool band = false);

}  // namespace nfd
