// The GPU path end to end (gpu_decode.h), as extract_cpu.cpp is on the CPU: the sparse levels
// (levels.cpp), then the mesher of the field type (mesh_sdf.cpp, mesh_udf.cpp).
#include "gpu_decode.h"

#include "levels.h"

namespace nfd::gpu {

uint64_t live_bytes(const Device& device) { return device.vk->live_bytes(); }
uint64_t peak_bytes(const Device& device) { return device.vk->peak_bytes(); }
void reset_peak_bytes(Device& device) { device.vk->reset_peak_bytes(); }

nfd_result extract_mesh(Device& device, const Geometry& geometry, uint32_t resolution,
                        MeshData* mesh, ExtractStats* stats) {
    if (resolution < NFD_MIN_RESOLUTION || resolution > NFD_MAX_RESOLUTION)
        return NFD_ERROR_LIMIT_EXCEEDED;
    ExtractStats st;
    const auto t_field = Clock::now();
    DeviceNetwork net;
    NFD_TRY(upload_network(device, geometry.network, &net));
    if (geometry.field == FieldType::Udf) NFD_TRY(prepare_field(device, net, true));
    FinestLevel finest(*device.vk);
    NFD_TRY(build_levels(device, net, geometry, resolution, &finest));
    st.points_evaluated = finest.points_evaluated;
    st.seconds_field = seconds_since(t_field);

    MeshData out;
    const uint32_t parents = finest.parents.kept;
    if (parents >= 1u << 26) return NFD_ERROR_LIMIT_EXCEEDED;  // mc_emit's k << 6 | edge records
    if (parents > 0) {
        const auto t_mesh = Clock::now();
        NFD_TRY(geometry.field == FieldType::Udf
                    ? mesh_udf(device, net, finest, &out, &st)
                    : mesh_sdf(device, finest, &out, &st));
        st.seconds_mesh = seconds_since(t_mesh);
    }
    *mesh = std::move(out);
    if (stats) *stats = st;
    return NFD_SUCCESS;
}

}  // namespace nfd::gpu
