// The GPU path of a progressive extraction (progressive.h): LevelBuilder one level per step, and
// mesh_level on the levels asked for, which keep their storage for the next step. A meshed UDF
// level's gradients serve the next level's corners when that level is meshed too
// (CarriedGradients), as on the CPU (progressive_cpu.cpp).
#include <new>

#include "gpu_decode.h"
#include "levels.h"

namespace nfd::gpu {
namespace {

class GpuExtraction final : public Extraction {
public:
    GpuExtraction(Device& device, const Geometry& geometry, uint32_t resolution, uint32_t mesh_mask,
                  bool band)
        : device_(device), geometry_(geometry), resolution_(resolution), job_(device, true),
          mesh_mask_(mesh_mask), band_(band) {}

    // The network uploaded and its pipelines started before the first step, which the host
    // evaluates meanwhile (levels.h, HostTop); the second step waits for them if need be.
    nfd_result prepare() {
        NFD_TRY(job_.init());
        NFD_TRY(device_network(device_, geometry_.network, &net_));
        NFD_TRY(prepare_fields(device_, *net_, geometry_.field));
        levels_.reset(new (std::nothrow)
                          LevelBuilder(job_, *net_, geometry_, resolution_, nullptr, band_,
                                       mesh_mask_));
        return levels_ ? NFD_SUCCESS : NFD_ERROR_OUT_OF_MEMORY;
    }

    nfd_result step(MeshData* mesh, ExtractStats* stats, LevelReport* report) override {
        if (levels_->done()) return NFD_ERROR_INTERNAL;
        const auto t_field = Clock::now();
        const uint64_t points_before = levels_->level().points_evaluated;
        NFD_TRY(levels_->step(carried_.get()));
        seconds_field_ += seconds_since(t_field);
        const uint32_t l = levels_->current();
        LevelReport r;
        r.level = l;
        r.cells_per_axis = levels_->level().push.child_cells;
        r.done = levels_->done();
        r.meshed = meshes(l);
        r.points_evaluated = levels_->level().points_evaluated - points_before;
        if (r.meshed) {
            ExtractStats st;
            st.points_evaluated = levels_->level().points_evaluated;
            st.seconds_field = seconds_field_;
            // The list this level makes is carried when the next level is meshed too, unless
            // the host evaluated it (HostTop): the next level's list is the device's, as in a
            // one-shot decode of that level, whose mesh must be the same to the byte.
            std::unique_ptr<CarriedGradients> carry;
            if (udf() && !levels_->done() && meshes(l - 1) && !levels_->level().top.values) {
                carry.reset(new (std::nothrow) CarriedGradients(*device_.vk));
                if (!carry) return NFD_ERROR_OUT_OF_MEMORY;
            }
            NFD_TRY(mesh_level(job_, *net_, geometry_.field, levels_->level(), nullptr,
                               {mesh, nullptr}, &st, {carried_.get(), carry.get()}));
            carried_ = std::move(carry);
            r.gradients_evaluated = st.gradients_evaluated;
            *stats = st;
        }
        if (!r.done) {
            const bool mesh_next = meshes(l - 1);
            r.next_host_bytes = levels_->next_step_host_bytes(mesh_next);
            r.next_device_bytes =
                levels_->next_step_device_bytes(mesh_next, udf(), carried_ != nullptr);
        }
        *report = r;
        return NFD_SUCCESS;
    }

private:
    bool meshes(uint32_t level) const { return mesh_mask_ >> level & 1; }
    bool udf() const { return geometry_.field == FieldType::Udf; }
    Device& device_;
    const Geometry& geometry_;
    const uint32_t resolution_;
    std::shared_ptr<DeviceNetwork> net_;
    Job job_;
    std::unique_ptr<LevelBuilder> levels_;
    std::unique_ptr<CarriedGradients> carried_;  // the last meshed UDF level's, for the next
    const uint32_t mesh_mask_;
    const bool band_;
    double seconds_field_ = 0;
};

}  // namespace

nfd_result make_extraction(Device& device, const Geometry& geometry, uint32_t resolution,
                           uint32_t mesh_mask, bool band, std::unique_ptr<Extraction>* out) {
    auto extraction =
        std::make_unique<GpuExtraction>(device, geometry, resolution, mesh_mask, band);
    NFD_TRY(extraction->prepare());
    *out = std::move(extraction);
    return NFD_SUCCESS;
}

}  // namespace nfd::gpu
