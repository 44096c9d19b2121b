// The CPU path end to end (extract.h): the sparse grid, then the mesher of the field type, then
// the original frame.
#include <algorithm>
#include <chrono>

#include "extract.h"
#include "marching.h"
#include "mc_tables.h"

namespace nfd {

uint64_t mesh_bytes_bound(const LevelSize& level) {
    // march_cells (marching.h): a case and an emitted-triangle mask per visited cell (and on a
    // probed coarsest level the cells meshed, GridLevel::meshed_cells), three counts per run of
    // them; an owner slot per edge of the level's vertices (3 per vertex); the indices at the
    // table's most triangles per cell; positions and normals, one vertex per grid edge at most.
    const mc::Tables& t = mc::tables();
    const uint64_t most_triangles = *std::max_element(t.triangle_count, t.triangle_count + 256);
    const uint64_t runs = level.cells / marching_detail::kOrderRun + 1;
    return 3 * level.cells + 24 * (runs + 1) + 12 * level.vertices +
           12 * most_triangles * level.cells + 2 * 12 * level.edges;
}

nfd_result mesh_level_cpu(const Geometry& geometry, GridBuilder& builder, MeshData* mesh,
                          ExtractStats* stats) {
    const bool udf = geometry.field == FieldType::Udf;
    if (udf) builder.evaluate_udf_gradients();
    const GridLevel& level = builder.grid().levels[builder.current()];
    const auto t_mesh = std::chrono::steady_clock::now();
    MeshData out;
    ExtractStats st;
    const OutputFrame frame{geometry.scale,
                            {geometry.emit_center(0), geometry.emit_center(1), geometry.emit_center(2)}};
    const nfd_result m = udf ? mesh_udf_cpu(level, frame, builder.threads(), &out, &st.active_cells)
                             : mesh_sdf_cpu(level, frame, builder.threads(), &out, &st.active_cells);
    if (m != NFD_SUCCESS) return m;
    st.seconds_mesh =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_mesh).count();
    const GridStats& grid = builder.grid().stats;
    st.seconds_field = grid.seconds;
    st.points_evaluated = grid.points_evaluated;
    st.gradients_evaluated = grid.gradients_evaluated;
    *mesh = std::move(out);
    *stats = st;
    return NFD_SUCCESS;
}

nfd_result extract_mesh_cpu(const Geometry& geometry, uint32_t resolution, MeshData* mesh,
                            ExtractStats* stats, unsigned threads, bool band, bool follow_finest) {
    if (resolution < NFD_MIN_RESOLUTION || resolution > NFD_MAX_RESOLUTION)
        return NFD_ERROR_LIMIT_EXCEEDED;
    GridBuilder builder(geometry, resolution, threads, band, follow_finest, /*gradient_levels=*/1);
    do builder.step();
    while (!builder.done());
    ExtractStats st;
    const nfd_result r = mesh_level_cpu(geometry, builder, mesh, &st);
    if (r == NFD_SUCCESS && stats) *stats = st;
    return r;
}

}  // namespace nfd
