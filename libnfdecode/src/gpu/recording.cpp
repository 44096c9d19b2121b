// A whole decode recorded into a host's command buffer (gpu_decode.h; nfdecode.h, nfd_recording):
// the levels (LevelBuilder with a plan) and the mesher of the field type, every count on the
// device, the mesh left in buffers of the plan's capacities with an indirect draw record. The
// same stages as the library's own submissions, so the same mesh, byte for byte.
#include <algorithm>
#include <cstring>
#include <new>

#include "../grid.h"
#include "gpu_decode.h"
#include "levels.h"

namespace nfd::gpu {
namespace {

// Default capacities per (resolution / 64)^2 (nfdecode.h, nfd_recording_options): what 9 assets
// at 64-256 needed (bench/recording.cpp; bench/RESULTS.md "Recording"): cells 2250-14860,
// gradient points 7871-45037, vertices 2600-8822 and triangles 4642-15668 but for the dragon's
// 38744 and 46784. The dragon's mesh takes a second try.
constexpr uint64_t kDefaultCellsPerQ = 16384, kDefaultGradientsPerQ = 49152,
                   kDefaultVerticesPerQ = 16384, kDefaultTrianglesPerQ = 32768;

}  // namespace

class Recording {
public:
    Recording(Device& device, const Geometry& geometry, uint32_t resolution, const Capacities& c)
        : device_(device), geometry_(geometry), resolution_(resolution), plan_{c},
          job_(device, false), mesh_(*device.vk) {}
    ~Recording() { levels_.reset(); }  // job_ then frees what the host's commands used

    nfd_result prepare() {
        NFD_TRY(job_.init());
        NFD_TRY(device_network(device_, geometry_.network, &net_));
        NFD_TRY(prepare_fields(device_, *net_, geometry_.field));
        mesh_.vertex_capacity = plan_.vertices;
        mesh_.triangle_capacity = plan_.triangles;
        NFD_TRY(job_.new_slot(&mesh_.vertex_slot));
        NFD_TRY(job_.new_slot(&mesh_.triangle_slot));
        NFD_TRY(job_.new_slot(&mesh_.gradient_slot));
        NFD_TRY(job_.new_slot(&mesh_.emitting_slot));
        return mesh_.make();
    }

    nfd_result record(VkCommandBuffer commands) {
        if (recorded_) return NFD_ERROR_INVALID_ARGUMENT;
        recorded_ = true;
        NFD_TRY(device_.vk->begin_external(job_.batch(), commands));
        const nfd_result r = record_stages();
        device_.vk->end_external(job_.batch());
        return r;
    }

    nfd_result finish(RecordingTotals* totals) {
        if (!recorded_) return NFD_ERROR_INVALID_ARGUMENT;
        if (finished_) {
            *totals = totals_;
            return totals_.overflowed ? NFD_ERROR_CAPACITY_EXCEEDED : NFD_SUCCESS;
        }
        NFD_TRY(job_.refresh());
        RecordingTotals t;
        t.overflowed = job_.overflowed();
        Capacities& need = t.needed;
        need = plan_;
        for (const auto& [level, slot] : levels_->kept_slots())
            need.cells = std::max(need.cells, cells_for(level, job_.counter(slot)));
        need.vertices = std::max(need.vertices, job_.counter(mesh_.vertex_slot));
        need.triangles = std::max(need.triangles, job_.counter(mesh_.triangle_slot));
        if (geometry_.field == FieldType::Udf)
            need.gradient_points =
                std::max(need.gradient_points, job_.counter(mesh_.gradient_slot));
        if (!t.overflowed) {
            t.vertices = job_.counter(mesh_.vertex_slot);
            t.triangles = job_.counter(mesh_.triangle_slot);
            t.stats = stats_;
            t.stats.points_evaluated = levels_->level().points_evaluated;  // the host top's part
            for (uint32_t slot : levels_->point_slots())
                t.stats.points_evaluated += job_.counter(slot);
            if (geometry_.field == FieldType::Udf)
                t.stats.gradients_evaluated = job_.counter(mesh_.gradient_slot);
            t.stats.active_cells = job_.counter(mesh_.emitting_slot);
        }
        totals_ = t;
        finished_ = true;
        *totals = t;
        // The host has waited: the levels, the scratch its commands used and their descriptor
        // sets go; the mesh buffers stay, as the engine may still draw from them.
        levels_.reset();
        job_.release_batch();
        return t.overflowed ? NFD_ERROR_CAPACITY_EXCEEDED : NFD_SUCCESS;
    }

    nfd_result read_mesh(MeshData* mesh, ExtractStats* stats) const {
        if (!finished_ || totals_.overflowed) return NFD_ERROR_INVALID_ARGUMENT;
        MeshData m;
        try {
            m.positions.resize(3 * size_t(totals_.vertices));
            m.normals.resize(3 * size_t(totals_.vertices));
            m.indices.resize(3 * size_t(totals_.triangles));
        } catch (const std::bad_alloc&) {
            return NFD_ERROR_OUT_OF_MEMORY;
        }
        Context& vk = *device_.vk;
        NFD_TRY(vk.download(*mesh_.positions, 0, m.positions.data(), m.positions.size() * 4));
        NFD_TRY(vk.download(*mesh_.normals, 0, m.normals.data(), m.normals.size() * 4));
        NFD_TRY(vk.download(*mesh_.indices, 0, m.indices.data(), m.indices.size() * 4));
        *mesh = std::move(m);
        *stats = totals_.stats;
        return NFD_SUCCESS;
    }

    DeviceMeshHandles handles() const {
        auto handle = [](const Buffer* b) {
            uint64_t h = 0;
            static_assert(sizeof(VkBuffer) <= sizeof(h), "a handle fits 64 bits");
            std::memcpy(&h, &b->buffer, sizeof(VkBuffer));
            return h;
        };
        return {handle(mesh_.positions), handle(mesh_.normals), handle(mesh_.indices),
                handle(mesh_.draw),      mesh_.vertex_capacity, mesh_.triangle_capacity};
    }

private:
    // Every level, then the mesher, into the host's buffer: the stages of extract_mesh with a
    // plan, so nothing is submitted and nothing read.
    nfd_result record_stages() {
        levels_.reset(new (std::nothrow)
                          LevelBuilder(job_, *net_, geometry_, resolution_, &plan_));
        if (!levels_) return NFD_ERROR_OUT_OF_MEMORY;
        do NFD_TRY(levels_->step());
        while (!levels_->done());
        return mesh_level(job_, *net_, geometry_.field, levels_->level(), &plan_,
                          {nullptr, &mesh_}, &stats_);
    }

    // The level-1 capacity whose plan gives `level` room for `cells` kept cells (Plan::cells).
    static uint32_t cells_for(uint32_t level, uint32_t cells) {
        if (level <= 1) return cells;
        const uint64_t per_level = (uint64_t(cells) + 1) / 2;
        if (per_level <= 64) return 0;
        return uint32_t(std::min<uint64_t>((per_level - 64) << (2 * (level - 1)), UINT32_MAX));
    }

    Device& device_;
    const Geometry& geometry_;
    const uint32_t resolution_;
    const Plan plan_;
    Job job_;
    std::shared_ptr<DeviceNetwork> net_;
    DeviceMesh mesh_;
    std::unique_ptr<LevelBuilder> levels_;
    ExtractStats stats_;
    RecordingTotals totals_;
    bool recorded_ = false, finished_ = false;
};

Capacities default_capacities(uint32_t resolution) {
    const uint64_t q = (uint64_t(resolution) * resolution + 4095) / 4096;
    auto cap = [&](uint64_t per) { return uint32_t(std::min<uint64_t>(per * q, UINT32_MAX)); };
    return {cap(kDefaultCellsPerQ), cap(kDefaultGradientsPerQ), cap(kDefaultVerticesPerQ),
            cap(kDefaultTrianglesPerQ)};
}

nfd_result make_recording(Device& device, const Geometry& geometry, uint32_t resolution,
                          const Capacities& capacities, std::unique_ptr<Recording>* out) {
    if (resolution < NFD_MIN_RESOLUTION || resolution > NFD_MAX_RESOLUTION)
        return NFD_ERROR_LIMIT_EXCEEDED;
    std::unique_ptr<Recording> r(new (std::nothrow)
                                     Recording(device, geometry, resolution, capacities));
    if (!r) return NFD_ERROR_OUT_OF_MEMORY;
    NFD_TRY(r->prepare());
    *out = std::move(r);
    return NFD_SUCCESS;
}

void destroy_recording(Recording* recording) { delete recording; }
DeviceMeshHandles device_mesh(const Recording& recording) { return recording.handles(); }
nfd_result record(Recording& recording, void* command_buffer) {
    return recording.record(static_cast<VkCommandBuffer>(command_buffer));
}
nfd_result finish(Recording& recording, RecordingTotals* totals) {
    return recording.finish(totals);
}
nfd_result read_mesh(const Recording& recording, MeshData* mesh, ExtractStats* stats) {
    return recording.read_mesh(mesh, stats);
}

}  // namespace nfd::gpu
