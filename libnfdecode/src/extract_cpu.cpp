// The CPU path end to end (extract.h): the sparse grid, then the mesher of the field type, then
// the original frame.
#include <chrono>

#include "extract.h"

namespace nfd {

nfd_result extract_mesh_cpu(const Geometry& geometry, uint32_t resolution, MeshData* mesh,
                            ExtractStats* stats, unsigned threads) {
    const bool udf = geometry.field == FieldType::Udf;
    GridOptions options;
    options.udf_gradients = udf;
    SparseGrid grid;
    const nfd_result r = build_grid_cpu(geometry, resolution, options, &grid, threads);
    if (r != NFD_SUCCESS) return r;

    const auto t_mesh = std::chrono::steady_clock::now();
    MeshData out;
    ExtractStats st;
    const nfd_result m = udf ? mesh_udf_cpu(grid, &out, &st.active_cells)
                             : mesh_sdf_cpu(grid, &out, &st.active_cells);
    if (m != NFD_SUCCESS) return m;
    for (size_t i = 0; i < out.positions.size(); ++i)
        out.positions[i] = out.positions[i] * geometry.scale + geometry.center[i % 3];
    st.seconds_mesh =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_mesh).count();
    st.seconds_field = grid.stats.seconds;
    st.points_evaluated = grid.stats.points_evaluated;
    st.gradients_evaluated = grid.stats.gradients_evaluated;
    *mesh = std::move(out);
    if (stats) *stats = st;
    return NFD_SUCCESS;
}

}  // namespace nfd
