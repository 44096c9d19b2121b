// The GPU path end to end (gpu_decode.h), as extract_cpu.cpp is on the CPU: the sparse levels
// (levels.cpp), then the mesher of the field type (mesh_sdf.cpp, mesh_udf.cpp).
#include "gpu_decode.h"

#include "levels.h"

namespace nfd::gpu {

nfd_result mesh_level(Job& job, DeviceNetwork& net, FieldType field, FinestLevel& level,
                      const Plan* plan, MeshTarget target, ExtractStats* stats,
                      GradientCarry carried) {
    const uint32_t parents = level.parents.capacity;
    if (parents >= 1u << 26) return NFD_ERROR_LIMIT_EXCEEDED;  // mc_emit's k << 6 | edge records
    MeshData out;
    MeshTarget to = target;
    if (target.host) to.host = &out;
    if (parents > 0) {
        const auto t_mesh = Clock::now();
        NFD_TRY(field == FieldType::Udf ? mesh_udf(job, net, level, plan, to, stats, carried)
                                        : mesh_sdf(job, level, to, stats));
        stats->seconds_mesh = seconds_since(t_mesh);
    }
    if (target.host) *target.host = std::move(out);
    return NFD_SUCCESS;
}

nfd_result extract_mesh(Device& device, const Geometry& geometry, uint32_t resolution,
                        MeshData* mesh, ExtractStats* stats, bool band) {
    if (resolution < NFD_MIN_RESOLUTION || resolution > NFD_MAX_RESOLUTION)
        return NFD_ERROR_LIMIT_EXCEEDED;
    ExtractStats st;
    const auto t_field = Clock::now();
    std::shared_ptr<DeviceNetwork> uploaded;
    NFD_TRY(device_network(device, geometry.network, &uploaded));
    DeviceNetwork& net = *uploaded;
    NFD_TRY(prepare_fields(device, net, geometry.field));
    Job job(device, true);
    NFD_TRY(job.init());
    LevelBuilder levels(job, net, geometry, resolution, nullptr, band);
    do NFD_TRY(levels.step());
    while (!levels.done());
    st.points_evaluated = levels.level().points_evaluated;
    st.seconds_field = seconds_since(t_field);
    NFD_TRY(mesh_level(job, net, geometry.field, levels.level(), nullptr, {mesh, nullptr}, &st));
    if (stats) *stats = st;
    return NFD_SUCCESS;
}

}  // namespace nfd::gpu
