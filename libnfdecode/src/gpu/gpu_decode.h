// The Vulkan compute path: what api.cpp calls. Implemented in gpu/ over the shaders in shaders/,
// one file per stage, each with its CPU twin: field.cpp (network.cpp), levels.cpp (grid.cpp),
// mesh_sdf.cpp and mesh_udf.cpp (mesh_sdf_cpu.cpp, mesh_udf_cpu.cpp); device.cpp holds the
// kernel table, vk_context.cpp the Vulkan layer.
#pragma once
#include <cstddef>
#include <memory>
#include <string>

#include "../extract.h"
#include "../mesh.h"
#include "../network.h"
#include "../progressive.h"
#include "nfdecode/nfdecode.h"

namespace nfd::gpu {

class Device;  // Vulkan instance/device/queue (own or adopted), pipelines, scratch buffers

// Creates a headless compute device, or adopts the host's when `adopt` is not null; its
// pipeline cache starts from `pipeline_cache` where that is an intact envelope made on it.
// NFD_ERROR_DEVICE_UNAVAILABLE when no Vulkan loader/ICD/device with a compute queue exists, and
// with `hardware_only` (no `adopt`) when no hardware GPU can be there or the device picked is a
// CPU implementation (lavapipe), refused before any pipeline is made; *declined then says which,
// for nfd_context_device_reason.
nfd_result create_device(const nfd_vulkan_device* adopt, bool enable_validation,
                         std::unique_ptr<Device>* out, bool hardware_only = false,
                         std::string* declined = nullptr, const void* pipeline_cache = nullptr,
                         size_t pipeline_cache_size = 0);
// The device's pipeline cache in its envelope (nfd_context_get_pipeline_cache).
nfd_result pipeline_cache(const Device& device, std::vector<uint8_t>* out);
// False where no hardware GPU can be present: on Linux every GPU driver works through a device
// node (DRM for Mesa's and AMD's, /dev/nvidia* for NVIDIA's, /dev/dxg under WSL, /dev/kgsl* and
// /dev/mali* on phones and boards), so with none only a CPU implementation could load, and an
// instance made to find that out costs 35-80 ms (it loads lavapipe and LLVM). True elsewhere.
bool gpu_device_node_present();
void destroy_device(Device* device);  // also what the unique_ptr's deleter calls
const char* device_name(const Device& device);
// The threads of the host work of its decodes (the context's cpu_threads; 0 = hardware
// concurrency): the coarsest grid level, evaluated by the C++ evaluator (levels.h, HostTop).
void set_host_threads(Device& device, unsigned threads);
// The device memory its buffers hold, and the peak since the last reset: what the progressive
// extraction's bounds of the next step (LevelReport::next_device_bytes) and the queue's device
// budget are checked against.
struct DeviceMemory {
    uint64_t live = 0, peak = 0;
    uint64_t buffers = 0, allocations = 0;  // made so far: buffers, VkDeviceMemory objects
    uint64_t live_allocations = 0;          // VkDeviceMemory objects now
};
DeviceMemory device_memory(const Device& device);
// Whether the device's buffers are mapped (unified memory) or reached through staging copies.
bool unified_memory(const Device& device);
// How many networks the device has uploaded (each once while cached: device.h, device_network).
uint64_t networks_uploaded(const Device& device);
void reset_device_memory_peak(Device& device);

// Starts compiling the field pipelines that a decode of a network of this shape (weights and
// biases may be empty: peek_geometry_network's) and field type will need, on a thread of the
// device, and returns at once: so that a decode created later finds them built, or waits only for
// the rest of the compile. Only a hint: a shape the device cannot run, a failed compile, or more
// than kMaxWarmers (field.cpp) compiles already running are ignored (the decode then compiles as before and
// reports any error itself). The device joins its threads before it is destroyed.
void warm_field_pipelines(Device& device, const Network& shape, FieldType field);

// Network outputs at n unit-frame points (xyz interleaved; output_width() floats per point): the
// GPU twin of evaluate_cpu.
nfd_result evaluate(Device& device, const Network& network, const float* unit_xyz, size_t n,
                    float* out);
// Values and gradients (3 floats per point, d value / d unit-frame coordinate): the GPU twin of
// evaluate_gradient_cpu.
nfd_result evaluate_gradient(Device& device, const Network& network, const float* unit_xyz,
                             size_t n, float* values, float* gradients);

// The GPU twin of extract_mesh_cpu with `band` (and, for a UDF without `band`, its
// `follow_finest`), for SDF and UDF: same grid, same rules, same mesh conventions and topology
// (triangles and vertices in another order).
nfd_result extract_mesh(Device& device, const Geometry& geometry, uint32_t resolution,
                        MeshData* mesh, ExtractStats* stats, bool band = false);

// The GPU path of a progressive extraction (progressive.h); `mesh_mask` bit l meshes grid level
// l; `band` as for extract_mesh. Device and geometry must outlive it.
nfd_result make_extraction(Device& device, const Geometry& geometry, uint32_t resolution,
                           uint32_t mesh_mask, bool band, std::unique_ptr<Extraction>* out);

// ---- a decode recorded into a host's command buffer (recording.cpp; nfd_recording) -------------
class Recording;

// Capacities of a recording (nfdecode.h, nfd_recording_options): kept cells of level 1 (coarser
// levels scaled from it, levels.h Plan), the UDF's gradient points, the mesh.
struct Capacities {
    uint32_t cells = 0, gradient_points = 0, vertices = 0, triangles = 0;
};
// The defaults for a resolution (nfdecode.h documents the formula).
Capacities default_capacities(uint32_t resolution);

// What a recorded decode produced, read after the host's wait. `needed`: capacities that would
// have held every total counted (those past the first overflow are not counted).
struct RecordingTotals {
    bool overflowed = false;
    uint32_t vertices = 0, triangles = 0;
    Capacities needed;
    ExtractStats stats;
};

// The mesh buffers (VkBuffer handles as integers) and their capacities.
struct DeviceMeshHandles {
    uint64_t positions = 0, normals = 0, indices = 0, draw = 0;
    uint32_t vertex_capacity = 0, triangle_capacity = 0;
};

// Uploads the network, makes the pipelines and the mesh buffers. Device and geometry must outlive
// the recording.
nfd_result make_recording(Device& device, const Geometry& geometry, uint32_t resolution,
                          const Capacities& capacities, std::unique_ptr<Recording>* out);
void destroy_recording(Recording* recording);
DeviceMeshHandles device_mesh(const Recording& recording);
// Records the whole decode into `command_buffer` (a VkCommandBuffer in the recording state), once.
nfd_result record(Recording& recording, void* command_buffer);
// After the host's wait: the totals; then read_mesh copies the mesh (and its stats) to the host,
// NFD_ERROR_INVALID_ARGUMENT before a finish without overflow.
nfd_result finish(Recording& recording, RecordingTotals* totals);
nfd_result read_mesh(const Recording& recording, MeshData* mesh, ExtractStats* stats);

}  // namespace nfd::gpu

namespace std {
template <>
struct default_delete<nfd::gpu::Device> {
    void operator()(nfd::gpu::Device* d) const { nfd::gpu::destroy_device(d); }
};
template <>
struct default_delete<nfd::gpu::Recording> {
    void operator()(nfd::gpu::Recording* r) const { nfd::gpu::destroy_recording(r); }
};
}  // namespace std
