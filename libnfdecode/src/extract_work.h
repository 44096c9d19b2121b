// A queue job's work today (queue.h, JobWork): the whole mesh extraction of nfd_mesh_extract as
// one step, on the CPU or the Vulkan device, with an upper bound of the memory it takes.
#pragma once
#include <cstdint>

#include "network.h"
#include "queue.h"

namespace nfd {
namespace gpu {
class Device;
}

// Upper bound of what one extraction (extract_mesh_cpu or gpu::extract_mesh) of `geometry` at
// `resolution` holds at its peak: the result mesh included, the geometry copy a job keeps
// included. Measured, not derived (extract_work.cpp gives the measurements and the margin): the
// band of the sparse grid, and so the memory, follows the surface's area, which no cap bounds.
MemoryBytes extract_bytes_bound(const Geometry& geometry, uint32_t resolution, bool vulkan);

// One step: the extraction; it finishes the job and delivers its mesh. Keeps a copy of the
// geometry, so that the asset may be destroyed while the job is pending. `device` null: the CPU
// path with `cpu_threads`.
//
// For the integrator of the progressive extraction: replace this by one step per grid level,
// next_step_bytes() being the extraction's bound of its next level plus what it keeps of the
// earlier ones. Queue::run_steps then keeps the job's reservation between steps and waits on the
// worker when the next level does not fit. Two such jobs that both hold memory and both wait can
// block each other (none releases): before allowing several workers to hold memory between
// steps, either reserve a job's final-level bound when it starts, or let pending jobs that hold
// nothing wait while a job holding memory waits to grow (start order before priority).
// For a stream: its job's steps parse what has arrived; a job with nothing to parse must leave
// its worker (back to Job::Shared::pending, woken by the stream's feed) rather than wait on it.
class ExtractWork final : public JobWork {
public:
    ExtractWork(const Geometry& geometry, uint32_t resolution, gpu::Device* device,
                unsigned cpu_threads);
    MemoryBytes next_step_bytes() const override { return bound_; }
    nfd_result step(StepResult* out) override;

private:
    Geometry geometry_;
    uint32_t resolution_;
    gpu::Device* device_;
    unsigned cpu_threads_;
    MemoryBytes bound_;
};

}  // namespace nfd
