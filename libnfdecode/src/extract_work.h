// A queue job's work (queue.h, JobWork): the progressive extraction (progressive.h) of one asset,
// one grid level per step, on the CPU or the Vulkan device, delivering the mesh of every level in
// its mask, with an upper bound of the memory each step holds.
#pragma once
#include <cstdint>
#include <memory>
#include <optional>

#include "colour.h"
#include "network.h"
#include "progressive.h"
#include "queue.h"

namespace nfd {
namespace gpu {
class Device;
}

// Upper bound of what one extraction (extract_mesh_cpu or gpu::extract_mesh) of `geometry` at
// `resolution` holds at its peak: the result mesh included, the geometry copy a job keeps
// included. Measured, not derived (extract_work.cpp gives the measurements and the margin). A job
// reserves it for its first step only, at the coarsest level's resolution (32 to 63): that step
// creates the extraction (on Vulkan: the network's upload and pipelines, whose driver memory no
// derivation bounds) and evaluates that level, as the one-shot extraction there does.
MemoryBytes extract_bytes_bound(const Geometry& geometry, uint32_t resolution, bool vulkan);

// Keeps a copy of the geometry and the colour field (none: geometry only), so that the asset may
// be destroyed while the job is pending; a delivered mesh is coloured by the step that meshed it.
// `mesh_mask`: bit l meshes grid level l (0 = the finest, always meshed). `device` null: the CPU
// path with `cpu_threads`. `limit`: a step whose reservation (below) exceeds a non-zero field
// fails with NFD_ERROR_LIMIT_EXCEEDED before it allocates (nfd_mesh_options.max_*_bytes).
// `band`: nfd_mesh_options.sample_band (the CPU path's GridBuilder `band`).
//
// The reservation of a step is what the job may hold when the step starts plus the extraction's
// bound of what the step allocates (LevelReport: a true bound, not measured). What it holds at a
// step's start is bounded by the previous step's reservation (it allocated at most its bound, and
// may have freed some), so the reservation only grows: the first step's measured bound, then each
// level's bound added. That counts the grid levels the extraction keeps and the meshes the job
// delivered (each inside the bound of the step that made it) without a second accounting of
// either; the sum over the levels is about 4/3 of the final level's bound (each level's band has
// about four times its parent's cells).
class ExtractWork final : public JobWork {
public:
    ExtractWork(const Geometry& geometry, std::optional<ColourField> colour, uint32_t resolution,
                uint32_t mesh_mask, gpu::Device* device, unsigned cpu_threads,
                MemoryBytes limit = {}, bool band = false);
    MemoryBytes next_step_bytes() const override { return held_ + next_; }
    nfd_result step(StepResult* out) override;
    void restart() override;

private:
    Geometry geometry_;
    std::optional<ColourField> colour_;
    const uint32_t resolution_, top_;
    uint32_t mesh_mask_;  // levels still to deliver: a restart does not deliver a level twice
    gpu::Device* device_;
    const unsigned cpu_threads_;
    const MemoryBytes limit_;
    const bool band_;
    std::unique_ptr<Extraction> extraction_;  // made by the first step
    MemoryBytes held_, next_;
    uint32_t levels_done_ = 0;  // ladder levels completed, the most over restarts
};

}  // namespace nfd
