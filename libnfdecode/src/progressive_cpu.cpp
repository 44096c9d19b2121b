// The CPU path of a progressive extraction (progressive.h): GridBuilder one level per step, and
// mesh_level_cpu on the levels asked for. A UDF level's gradients serve its mesh and those of the
// next level's corners that are its own (grid.h, GridBuilder::evaluate_udf_gradients).
#include "progressive.h"

namespace nfd {
namespace {

class CpuExtraction final : public Extraction {
public:
    CpuExtraction(const Geometry& geometry, uint32_t resolution, uint32_t mesh_mask,
                  unsigned threads, bool band)
        : geometry_(geometry),
          builder_(geometry, resolution, threads, band, false, /*gradient_levels=*/mesh_mask),
          mesh_mask_(mesh_mask) {}

    nfd_result step(MeshData* mesh, ExtractStats* stats, LevelReport* report) override {
        if (builder_.done()) return NFD_ERROR_INTERNAL;
        const GridStats before = builder_.grid().stats;
        builder_.step();
        const uint32_t l = builder_.current();
        if (meshes(l)) {
            const nfd_result m = mesh_level_cpu(geometry_, builder_, mesh, stats);
            if (m != NFD_SUCCESS) return m;
        }
        const GridStats& after = builder_.grid().stats;
        LevelReport r;
        r.level = l;
        r.cells_per_axis = builder_.grid().levels[l].cells_per_axis;
        r.done = builder_.done();
        r.meshed = meshes(l);
        r.points_evaluated = after.points_evaluated - before.points_evaluated;
        r.gradients_evaluated = after.gradients_evaluated - before.gradients_evaluated;
        if (!r.done) {
            r.next_host_bytes = builder_.next_step_bytes_bound();
            if (meshes(l - 1)) {
                // The mesher runs after the gradients (UDF) and keeps its mesh: both count.
                const uint64_t gradients = geometry_.field == FieldType::Udf
                                               ? builder_.next_gradients_bytes_bound()
                                               : 0;
                r.next_host_bytes += gradients + mesh_bytes_bound(builder_.next_level_size());
            }
        }
        *report = r;
        return NFD_SUCCESS;
    }

private:
    bool meshes(uint32_t level) const { return mesh_mask_ >> level & 1; }
    const Geometry& geometry_;
    GridBuilder builder_;
    const uint32_t mesh_mask_;
};

}  // namespace

std::unique_ptr<Extraction> make_extraction_cpu(const Geometry& geometry, uint32_t resolution,
                                                uint32_t mesh_mask, unsigned threads, bool band) {
    return std::make_unique<CpuExtraction>(geometry, resolution, mesh_mask, threads, band);
}

}  // namespace nfd
