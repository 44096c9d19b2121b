// nfd_grid_write_vdb's writer lives in a module of its own, libnfdecode_vdb.so (export_vdb.cpp,
// linked with OpenVDB), which libnfdecode loads on the first write. OpenVDB and what it pulls in
// (TBB, Boost iostreams, blosc, log4cplus) cost every process that maps them ~40 ms of dynamic
// linking (61k relocations, bench/RESULTS.md): now only processes that write .vdb files pay it,
// not every engine and decode that links libnfdecode. The module is the same build as the
// library: the call carries NFD_VERSION, and a module from another version refuses it.
#pragma once
#include <array>
#include <cstdint>

#include "nfdecode/nfdecode.h"

namespace nfd {

// Where a grid came from, for the VDB metadata: the .nfc file's name (null: not recorded) and its
// format version.
struct VdbSource {
    const char* file_name;
    uint32_t format_major, format_minor;
};

// OpenVDB file with one openvdb::FloatGrid "distance" holding `voxels` (the narrow band) with their
// index -> original transform (translated by `offset`, in double), and a Vec3SGrid "colour" on the
// same voxels when `colours` (rgb per voxel) is not null, as nfd_grid_write_vdb documents. In the
// module only; it may throw (OpenVDB, allocation): the entry below catches.
nfd_result write_vdb(const nfd_grid_voxels& voxels, const std::array<double, 3>& offset,
                     const float* colours, const VdbSource& source, const char* path);

// The module's one exported symbol, kVdbEntry: write_vdb behind a C signature that no exception
// crosses (std::bad_alloc -> NFD_ERROR_OUT_OF_MEMORY, anything else -> NFD_ERROR_INTERNAL).
struct VdbWriteCall {
    uint32_t decoder_version;  // NFD_VERSION of the caller; another gives UNSUPPORTED_FEATURE
    const nfd_grid_voxels* voxels;
    std::array<double, 3> offset;
    const float* colours;
    VdbSource source;
    const char* path;
};
using VdbWriteEntry = nfd_result (*)(const VdbWriteCall* call);
constexpr const char* kVdbEntry = "nfd_vdb_module_write";

// Library side (vdb_loader.cpp): the module's entry, loaded once per process (thread-safe), or
// null when no module can be loaded. Looked for, in order: $NFD_VDB_MODULE (a path); beside the
// binary that holds libnfdecode (the shared library, or the executable it is linked into); in
// ../<libdir> from there (a bin/ beside lib/, the build tree's bin-like folders beside its lib/);
// in the install prefix's libdir; by name on the loader's search path.
VdbWriteEntry vdb_module_entry();

}  // namespace nfd
