// OpenVDB output of the sparse grid's narrow band: the libnfdecode_vdb module (vdb_module.h).
// Compiled only with NFD_WITH_OPENVDB; OpenVDB's headers and exceptions stay inside this file.
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <cmath>
#include <fstream>
#include <new>
#include <string>

#include "vdb_module.h"

namespace nfd {

namespace {

// OpenVDB's transforms refuse (ArithmeticError) a voxel whose volume is under 3e-15 (its double
// tolerance, math::Tolerance: so a voxel size under 1.45e-5 in the file's units), and lose the
// scale to rounding when the translation exceeds it by 2^52. Found by fuzz_decode: a real shape
// a millimetre wide in metres, decoded at 256, has voxels of 7.8e-6.
bool transform_representable(double size, const openvdb::Vec3d& translation) {
    if (!(size * size * size >= 3.0e-15)) return false;
    for (int a = 0; a < 3; ++a)
        if (!(std::fabs(translation[a]) < size * 0x1p52)) return false;
    return true;
}

}  // namespace

nfd_result write_vdb(const nfd_grid_voxels& voxels, const std::array<double, 3>& offset,
                     const float* colours, const VdbSource& source, const char* path) {
    // The transform is double: a geo-referenced offset stays exact in it.
    const double voxel_size = voxels.voxel_size;
    const openvdb::Vec3d translation(offset[0] + double(voxels.origin[0]),
                                     offset[1] + double(voxels.origin[1]),
                                     offset[2] + double(voxels.origin[2]));
    if (!transform_representable(voxel_size, translation)) return NFD_ERROR_LIMIT_EXCEEDED;
    openvdb::initialize();  // registers the grid and metadata types; idempotent, thread-safe
    const bool sdf = voxels.field_type == NFD_FIELD_SDF;
    const openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(voxels.background);
    grid->setName("distance");
    grid->setGridClass(sdf ? openvdb::GRID_LEVEL_SET : openvdb::GRID_UNKNOWN);
    // OpenVDB samples sit at integer index points, as the grid's vertices do: original =
    // ijk * voxel_size + origin + offset is exactly a scale then a translation.
    const openvdb::math::Transform::Ptr transform =
        openvdb::math::Transform::createLinearTransform(voxel_size);
    transform->postTranslate(translation);
    grid->setTransform(transform);

    // The voxels come in 8^3 blocks aligned as OpenVDB's leaf nodes are, so the accessor's cached
    // leaf serves every voxel of a block after the first.
    openvdb::FloatGrid::Accessor accessor = grid->getAccessor();
    for (size_t n = 0; n < voxels.count; ++n) {
        const int32_t* c = voxels.ijk + 3 * n;
        accessor.setValueOn(openvdb::Coord(c[0], c[1], c[2]), voxels.values[n]);
    }
    // Off the band everything reads the background, +d*. The band is closed around the surface
    // and at least a cell thick on both sides, so the flood fill can give every inactive voxel and
    // tile enclosed by negative values -d* instead: a level set whose inside reads negative.
    if (sdf) openvdb::tools::signedFloodFill(grid->tree());
    openvdb::GridCPtrVec grids{grid};

    // Colour on the same active voxels and transform; off the band it means nothing (black).
    if (colours) {
        const openvdb::Vec3SGrid::Ptr colour = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
        colour->setName("colour");
        colour->setGridClass(openvdb::GRID_UNKNOWN);
        colour->setTransform(transform);
        openvdb::Vec3SGrid::Accessor rgb = colour->getAccessor();
        for (size_t n = 0; n < voxels.count; ++n) {
            const int32_t* c = voxels.ijk + 3 * n;
            const float* v = colours + 3 * n;
            rgb.setValueOn(openvdb::Coord(c[0], c[1], c[2]), openvdb::Vec3s(v[0], v[1], v[2]));
        }
        colour->insertMeta("nfc_colour_space", openvdb::StringMetadata("rgb 0..1, as encoded"));
        grids.push_back(colour);
    }

    if (source.file_name)
        grid->insertMeta("nfc_source_file", openvdb::StringMetadata(source.file_name));
    grid->insertMeta("nfc_field_type", openvdb::StringMetadata(sdf ? "sdf" : "udf"));
    grid->insertMeta("nfc_format_version",
                     openvdb::StringMetadata(std::to_string(source.format_major) + "." +
                                             std::to_string(source.format_minor)));
    grid->insertMeta("nfc_resolution", openvdb::Int32Metadata(int32_t(voxels.resolution)));
    grid->insertMeta("nfc_decoder",
                     openvdb::StringMetadata("libnfdecode " + std::to_string(NFD_VERSION_MAJOR) +
                                             "." + std::to_string(NFD_VERSION_MINOR) + "." +
                                             std::to_string(NFD_VERSION_PATCH)));

    // io::File would report a file it cannot open but not a failed write (a full disk leaves a
    // truncated file and no error); io::Stream writes the same format onto a stream we check. It
    // omits only the per-grid offsets that let readers skip grids in a file of many.
    std::ofstream out(path, std::ios::binary);
    if (!out) return NFD_ERROR_IO;
    out.exceptions(std::ios::failbit | std::ios::badbit);
    try {
        openvdb::io::Stream(out).write(grids);
        out.close();
    } catch (const std::ios::failure&) {
        return NFD_ERROR_IO;
    }
    return NFD_SUCCESS;
}

}  // namespace nfd

extern "C" __attribute__((visibility("default"))) nfd_result nfd_vdb_module_write(
    const nfd::VdbWriteCall* call) {
    if (!call || call->decoder_version != NFD_VERSION) return NFD_ERROR_UNSUPPORTED_FEATURE;
    try {
        return nfd::write_vdb(*call->voxels, call->offset, call->colours, call->source, call->path);
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    } catch (...) {
        return NFD_ERROR_INTERNAL;
    }
}
