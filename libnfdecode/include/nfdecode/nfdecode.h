/*
 * nfdecode.h — decoder for .nfc neural-field compressed 3D shapes (libnfdecode).
 *
 * The only public header of libnfdecode. C99/C++ compatible; no exception crosses it, no function
 * calls exit() or abort(). The bitstream is specified in FORMAT.md.
 *
 * Typical use:
 *
 *     nfd_context* ctx;  nfd_asset* asset;  nfd_mesh* mesh;
 *     if (nfd_context_create(NULL, &ctx) != NFD_SUCCESS) ...        // Vulkan, else CPU
 *     if (nfd_asset_create(bytes, size, &asset) != NFD_SUCCESS) ... // parse + verify + dequantize
 *     nfd_mesh_options mo = {0};                                    // zero = defaults
 *     if (nfd_mesh_extract(ctx, asset, &mo, &mesh) != NFD_SUCCESS) ...
 *     nfd_mesh_data data;  nfd_mesh_get_data(mesh, &data);          // positions/normals/indices
 *     nfd_mesh_destroy(mesh); nfd_asset_destroy(asset); nfd_context_destroy(ctx);
 *
 * Objects:
 *   nfd_context  a compute device (a Vulkan device created headless or adopted from the host
 *                engine, or the CPU) with its pipelines. Not thread-safe: use one context per
 *                thread, or serialise calls on it.
 *   nfd_asset    one parsed .nfc file: verified, decompressed, dequantized. Immutable after
 *                creation; may be shared by several contexts and threads.
 *   nfd_mesh     a decoded triangle mesh owned by the library. Immutable; thread-safe to read.
 *   nfd_grid     the field sampled on a sparse grid around the surface (the stage the meshes are
 *                extracted from), owned by the library. Immutable; thread-safe to read.
 *
 * Every create function writes its handle only on NFD_SUCCESS (and NULL otherwise, when the out
 * pointer itself is non-NULL). Every destroy function accepts NULL.
 */
#ifndef NFDECODE_NFDECODE_H
#define NFDECODE_NFDECODE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Every function of the library is declared NFD_API: exported from a shared build (all other
 * symbols are hidden), plain in a static one. Define NFD_SHARED when using a Windows DLL. */
#if defined(_WIN32) && defined(NFD_SHARED)
#ifdef NFD_BUILDING
#define NFD_API __declspec(dllexport)
#else
#define NFD_API __declspec(dllimport)
#endif
#elif defined(__GNUC__) || defined(__clang__)
#define NFD_API __attribute__((visibility("default")))
#else
#define NFD_API
#endif

/* The version of this header. nfd_version() gives the library's, which may differ from the
 * header's when linking a shared build: compare them to detect a mismatch. */
#define NFD_VERSION_MAJOR 0
#define NFD_VERSION_MINOR 13
#define NFD_VERSION_PATCH 20
#define NFD_MAKE_VERSION(major, minor, patch) (((major) << 16) | ((minor) << 8) | (patch))
#define NFD_VERSION NFD_MAKE_VERSION(NFD_VERSION_MAJOR, NFD_VERSION_MINOR, NFD_VERSION_PATCH)

/* The newest bitstream version this library reads (FORMAT.md, "Version policy"). */
#define NFD_FORMAT_MAJOR 1
#define NFD_FORMAT_MINOR 2

/* Hard caps from FORMAT.md. Inputs beyond them are rejected before any allocation. */
#define NFD_MAX_FILE_SIZE (64u * 1024u * 1024u)
#define NFD_MAX_CHUNK_SIZE (16u * 1024u * 1024u)
#define NFD_MAX_FREQUENCIES 24u
#define NFD_MAX_LAYERS 8u
#define NFD_MAX_WIDTH 512u
#define NFD_MAX_PARAMETERS (1024u * 1024u)
/* max_k |center_k| + scale of GEOM's frame (2^126): every emitted position stays finite in f32 */
#define NFD_MAX_FRAME_EXTENT 8.507059173023462e37

/* Caps of the mesh extraction. */
#define NFD_DEFAULT_RESOLUTION 256u
#define NFD_MIN_RESOLUTION 8u
#define NFD_MAX_RESOLUTION 1024u

/* ---------------------------------------------------------------------------------------------
 * Results. Zero is success; errors are negative and grouped by kind, so callers can test ranges:
 *   -1 .. -19   the input bytes (corrupt, truncated, newer than this library)
 *   -20 .. -39  the caller (bad argument, limits)
 *   -40 .. -59  resources (memory, device, files)
 *   -60         a defect in libnfdecode itself (please report it)
 * ------------------------------------------------------------------------------------------- */
typedef enum nfd_result {
    NFD_SUCCESS = 0,

    NFD_ERROR_TRUNCATED = -1,           /* fewer bytes than the file or a structure announces */
    NFD_ERROR_CORRUPT = -2,             /* bad magic, CRC, value, size, cap, or brotli stream */
    NFD_ERROR_UNSUPPORTED_VERSION = -3, /* another major format version */
    NFD_ERROR_UNSUPPORTED_FEATURE = -4, /* a critical chunk or field type this build can't decode */

    NFD_ERROR_INVALID_ARGUMENT = -20,   /* NULL where a pointer is required, bad option value */
    NFD_ERROR_LIMIT_EXCEEDED = -21,     /* request beyond a documented limit (e.g. resolution) */
    NFD_ERROR_CANCELLED = -22,          /* the job was cancelled (nfd_job_cancel, queue destroyed) */
    NFD_ERROR_NOT_READY = -23,          /* the job has no result yet */
    NFD_ERROR_CAPACITY_EXCEEDED = -24,  /* a recorded decode outgrew its capacities (0.3) */
    NFD_ERROR_NO_COLOUR = -25,          /* a colour call on an asset without colour (0.4) */

    NFD_ERROR_OUT_OF_MEMORY = -40,      /* host or device allocation failed; the context and
                                           queue stay usable, a later call may succeed */
    NFD_ERROR_DEVICE_UNAVAILABLE = -41, /* no usable Vulkan driver/device (CPU still works) */
    NFD_ERROR_DEVICE = -42,             /* a Vulkan call failed (device lost, ...). A lost device
                                           stays lost: every later call on that context gives
                                           this too; destroy it and create another (the CPU
                                           path is never taken behind a Vulkan context's back) */
    NFD_ERROR_IO = -43,                 /* a file could not be written */

    NFD_ERROR_INTERNAL = -60            /* an unexpected internal failure, caught at the API */
} nfd_result;

/* Static, human-readable, never NULL (unknown values give "unknown result"). */
NFD_API const char* nfd_result_string(nfd_result result);

/* The linked library's version, NFD_MAKE_VERSION(major, minor, patch). Thread-safe. */
NFD_API uint32_t nfd_version(void);

/* ---------------------------------------------------------------------------------------------
 * Option structs
 *
 * Every option struct begins with `struct_size`: set it to sizeof(the struct) as your header
 * declares it, and zero-initialise the rest (zero is every field's default). Later versions only
 * append fields; the library reads the fields that `struct_size` covers and takes the defaults for
 * the others, so a program built against an older header keeps working with a newer library.
 * struct_size = 0 is read as the first sized layout (version 0.2: the fields marked "0.2"), so that
 * `= {0}` keeps working. A struct_size smaller than that layout is NFD_ERROR_INVALID_ARGUMENT; a
 * larger one than this library knows (a newer header's struct) is accepted when the fields it does
 * not know are all zero, their defaults, and is NFD_ERROR_INVALID_ARGUMENT otherwise.
 * ------------------------------------------------------------------------------------------- */

/* ---------------------------------------------------------------------------------------------
 * Host memory (0.7)
 *
 * By default the library allocates host memory with the C++ runtime (operator new). A host that
 * manages its own (an engine's arenas, a budgeted or tracking heap) installs its functions, as
 * with brotli's alloc_func / free_func or meshopt_setAllocator. They serve every allocation whose
 * size follows from the input: the objects' handles, parsed networks, sparse grids and voxels,
 * meshes, stream buffers, the CPU evaluator's batches, marching-cubes bookkeeping, the brotli
 * decoder's state, the bytes of written .ply files. Not through them: fixed bookkeeping of a few
 * hundred bytes per object (a queue's job lists, thread objects, callbacks), threads' stacks, the
 * Vulkan driver's memory, the JSON text of a written .glb (a few KB), OpenVDB writing (OpenVDB's
 * own containers), and tables built once per process. bench/RESULTS.md ("Host memory hooks") measures the share.
 *
 * allocate(user, size) returns `size` bytes (never asked for 0) aligned to at least 16 bytes, or
 * NULL when it cannot: the call in progress then fails with NFD_ERROR_OUT_OF_MEMORY, leaving
 * nothing allocated behind (objects that existed before stay valid). deallocate(user, address)
 * frees an address allocate returned. Both are called from the caller's thread and from the
 * library's threads (queue workers, the CPU path's threads), at the same time: they must be
 * thread-safe.
 * ------------------------------------------------------------------------------------------- */
typedef struct nfd_allocator {
    uint32_t struct_size; /* 0.7: sizeof(nfd_allocator), or 0 */
    void* (*allocate)(void* user, size_t size);
    void (*deallocate)(void* user, void* address);
    void* user;           /* passed to both */
} nfd_allocator;

/* Installs `allocator` (copied) for the whole process; NULL goes back to the C++ runtime. Only
 * while nothing the current functions allocated is alive: before the first object is created, or
 * after the last is destroyed (every handle, including meshes and grids a caller still holds).
 * Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT when something is alive (nothing changes), for
 * a NULL function or a struct_size the library cannot read. Not thread-safe: no other nfd_* call may
 * run at the same time. */
NFD_API nfd_result nfd_set_allocator(const nfd_allocator* allocator);

/* ---------------------------------------------------------------------------------------------
 * Context
 * ------------------------------------------------------------------------------------------- */
typedef struct nfd_context nfd_context;

typedef enum nfd_device_kind {
    NFD_DEVICE_AUTO = 0,   /* an adopted device; else a hardware Vulkan device (discrete,
                              integrated or virtual GPU) if one can be created; else the CPU path,
                              also where the only Vulkan device is a CPU implementation such as
                              lavapipe, on which the C++ path decodes faster (0.3; 0.2 took it) */
    NFD_DEVICE_VULKAN = 1, /* Vulkan or fail with NFD_ERROR_DEVICE_UNAVAILABLE */
    NFD_DEVICE_CPU = 2     /* the plain C++ reference path, multi-threaded */
} nfd_device_kind;

/* A Vulkan device owned by the host engine, to be used instead of creating one. Handles are passed
 * as pointers/integers so that this header does not need vulkan.h: cast VkInstance etc. to void*.
 * The device must support Vulkan 1.1 (the kernels are SPIR-V 1.3; an older one gives
 * NFD_ERROR_DEVICE_UNAVAILABLE), have been created with a queue of `queue_family_index` supporting
 * compute, and outlive the context. libnfdecode submits to `queue`; the host must not use that queue from
 * another thread during a libnfdecode call (Vulkan's external synchronisation rule). */
typedef struct nfd_vulkan_device {
    void* instance;            /* VkInstance */
    void* physical_device;     /* VkPhysicalDevice */
    void* device;              /* VkDevice */
    void* queue;               /* VkQueue */
    uint32_t queue_family_index;
    void* get_instance_proc_addr; /* PFN_vkGetInstanceProcAddr; NULL = the loader's */
} nfd_vulkan_device;

/* Zero-initialise and set struct_size (see "Option structs"), then set what you need. */
typedef struct nfd_context_options {
    uint32_t struct_size;                 /* 0.2: sizeof(nfd_context_options), or 0 */
    nfd_device_kind device;               /* default NFD_DEVICE_AUTO */
    const nfd_vulkan_device* adopt;       /* NULL: create a headless device (first discrete GPU,
                                             else integrated, else a CPU implementation such as
                                             lavapipe, which AUTO declines) */
    uint32_t cpu_threads;                 /* threads of the CPU path, and of a Vulkan context's
                                             host work (colours, the coarsest grid level);
                                             0 = hardware concurrency. The calling thread and
                                             (0.13.7) worker threads that every context in the
                                             process shares: started on first need, as many as
                                             the largest cpu_threads - 1 asked (255 at most),
                                             idle between calls, kept until the process ends,
                                             scheduled as the queue's workers (see
                                             "Scheduling"); a child forked after them runs the
                                             CPU path on its calling thread */
    int enable_validation;                /* non-zero: enable VK_LAYER_KHRONOS_validation if present */
    /* (0.10) Bytes from nfd_context_get_pipeline_cache of an earlier context, e.g. read back from
     * a file in the user's cache directory: the pipelines they hold are not compiled again. Used
     * only where they were made on this device (vendor, device ID, driver version, pipeline-cache
     * UUID), by a library of this pointer size, and are intact (size, CRC-32); anything else
     * (another driver, a damaged or truncated file, more than 256 MiB, NULL) is ignored and the
     * cache starts empty: never an error. Not retained: may be freed when create returns. A CPU
     * context ignores them. */
    const void* pipeline_cache;
    size_t pipeline_cache_size;
} nfd_context_options;

/* options may be NULL (all defaults). Creating a Vulkan device compiles the pipelines; later
 * contexts reuse the driver's pipeline cache where it has one (within the process; across
 * processes through nfd_context_options.pipeline_cache).
 * Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT (out_context NULL, unknown device kind,
 * `adopt` with NFD_DEVICE_CPU, or with a NULL handle or a queue family index that the physical
 * device lacks or that has no compute); NFD_ERROR_DEVICE_UNAVAILABLE (VULKAN requested, or a
 * device to adopt given, and no usable device, or a build without Vulkan); NFD_ERROR_DEVICE;
 * NFD_ERROR_OUT_OF_MEMORY. AUTO without `adopt` never fails for lack of a device: it falls back to
 * the CPU when no Vulkan device can be created or initialised. */
NFD_API nfd_result nfd_context_create(const nfd_context_options* options, nfd_context** out_context);
NFD_API void nfd_context_destroy(nfd_context* context);

/* (0.10) The context's pipeline cache as bytes to store and give to a later context
 * (nfd_context_options.pipeline_cache), so that a program's first decode does not compile its
 * kernels again: what a driver keeps is its own (lavapipe 22.3 keeps nothing but its header;
 * drivers for GPUs keep the compiled kernels). The bytes hold the pipelines compiled so far: the
 * context's own, and the field kernels of the networks decoded or prepared.
 * With `data` NULL, *size receives the bytes needed. Else *size is the capacity of `data`: the
 * bytes are written and *size set to their count, or, if the cache has grown past *size since it
 * was asked (a compile on another of the context's threads), *size is set to the new need and
 * NFD_ERROR_LIMIT_EXCEEDED returned with nothing usable written. A CPU context: *size = 0.
 * Outcomes: NFD_SUCCESS; NFD_ERROR_LIMIT_EXCEEDED as above; NFD_ERROR_INVALID_ARGUMENT (context or
 * size NULL); NFD_ERROR_OUT_OF_MEMORY; NFD_ERROR_DEVICE. Thread safety: as other calls on the
 * context (its own background compiles may run meanwhile). */
NFD_API nfd_result nfd_context_get_pipeline_cache(const nfd_context* context, void* data,
                                                  size_t* size);

/* NFD_DEVICE_VULKAN or NFD_DEVICE_CPU: what the context actually runs on (AUTO for NULL). */
NFD_API nfd_device_kind nfd_context_device_kind(const nfd_context* context);
/* The device's name (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)" or "cpu"); owned by the context;
 * "" for NULL. */
NFD_API const char* nfd_context_device_name(const nfd_context* context);
/* Why the context runs on that device, for logs: "requested", "adopted", "auto: a GPU", "auto: no
 * Vulkan device", "auto: the only Vulkan device, <name>, is a CPU implementation (...)", or (0.8,
 * Linux) "auto: no GPU device node (...)": with no /dev/dri, /dev/nvidia* (nor WSL's or a phone's
 * GPU node), AUTO does not create a Vulkan instance at all, since only a CPU implementation could
 * load. Owned by the context; "" for NULL (0.3). */
NFD_API const char* nfd_context_device_reason(const nfd_context* context);

/* (0.13.9) What the context's device memory holds, for an engine's memory overlay and logs:
 * buffer bytes (each buffer's own: the measure of nfd_mesh_options.max_device_bytes and of the
 * queue's device budget) and device allocations (vkAllocateMemory) live now, and the buffers and
 * allocations made since the context was created. Buffers of up to 1 MiB share 8 MiB blocks, so
 * a decode's tens of buffers take a few allocations (a driver allows maxMemoryAllocationCount at
 * once, 4096 on some). All zero on a CPU context.
 * Set out->struct_size (sizeof(nfd_device_memory), or 0 for this layout) before the call.
 * Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT (NULL, or a non-zero struct_size below this
 * layout). Thread safety: any thread, beside the context's decodes (each count is read
 * atomically on its own, so they may be a moment apart). */
typedef struct nfd_device_memory {
    uint32_t struct_size;
    uint64_t live_bytes;        /* buffers' bytes now */
    uint64_t live_allocations;  /* VkDeviceMemory objects now: blocks and large buffers' own */
    uint64_t buffers_created;   /* since the context was created */
    uint64_t allocations_made;  /* since the context was created */
} nfd_device_memory;
NFD_API nfd_result nfd_context_get_device_memory(const nfd_context* context,
                                                 nfd_device_memory* out);

/* ---------------------------------------------------------------------------------------------
 * Asset: one .nfc file
 * ------------------------------------------------------------------------------------------- */
typedef struct nfd_asset nfd_asset;

typedef enum nfd_field_type { NFD_FIELD_SDF = 0, NFD_FIELD_UDF = 1 } nfd_field_type;

typedef struct nfd_asset_info {
    uint32_t format_major, format_minor; /* of the file (minor may exceed NFD_FORMAT_MINOR) */
    uint32_t file_size;                  /* bytes */
    nfd_field_type field_type;
    float truncation;                    /* d* in the unit frame */
    float center[3], scale;              /* original = unit * scale + center: GEOM's f32 frame
                                            (exact in f64: nfd_asset_get_frame) */
    uint32_t num_frequencies;            /* positional-encoding frequencies L */
    uint32_t num_layers;                 /* linear layers, output layer included */
    uint32_t layer_widths[NFD_MAX_LAYERS]; /* out_features of each layer */
    uint32_t bits;                       /* quantization bit width */
    uint32_t parameter_count;
    int has_colour;                      /* the file has a colour field (format 1.1, see "Colour") */
} nfd_asset_info;

/* Parses and fully verifies `size` bytes (magic, versions, CRCs, caps, brotli, exact sizes) and
 * dequantizes the weights. The bytes are not retained: the caller may free them on return.
 * Outcomes: NFD_SUCCESS; NFD_ERROR_TRUNCATED / CORRUPT / UNSUPPORTED_VERSION / UNSUPPORTED_FEATURE
 * for bad bytes; NFD_ERROR_INVALID_ARGUMENT for NULL pointers; NFD_ERROR_OUT_OF_MEMORY.
 * Allocation is bounded by the caps above, whatever the bytes say. */
NFD_API nfd_result nfd_asset_create(const void* bytes, size_t size, nfd_asset** out_asset);
NFD_API void nfd_asset_destroy(nfd_asset* asset);
NFD_API nfd_result nfd_asset_get_info(const nfd_asset* asset, nfd_asset_info* out_info);

/* (0.5) Positions and the offset: geo-referenced data.
 * Every position the library emits for an asset (mesh vertices, sampled points, a grid's origin,
 * recorded vertex buffers) and takes (nfd_asset_evaluate_colour's points) is in the original frame
 * relative to an offset: original = offset + position. The offset is (0, 0, 0) unless the file
 * stores its frame in 64 bits (exact64: format 1.2's `fram` chunk, which the encoder writes for
 * shapes far from their origin, e.g. LiDAR in UTM metres); then it is the frame's exact center, so
 * that positions stay small and exact in f32 while the offset keeps the far translation exact in
 * f64. Engines put the offset into the node's transform (the glTF writer does); the PLY writers
 * write offset + position as double coordinates; the VDB writer puts it into the double
 * transform. nfd_mesh_get_offset and nfd_grid_get_offset give it with each output. */
typedef struct nfd_asset_frame {
    uint32_t struct_size; /* set by the caller: sizeof(nfd_asset_frame), or 0 for this layout */
    int exact64;          /* the file stores its frame in f64 */
    double center[3];     /* original = unit * scale + center: the f64 frame, else GEOM's f32 one */
    double scale;
    double offset[3];     /* what positions are relative to: center if exact64, else (0, 0, 0) */
} nfd_asset_frame;

/* (0.5) Writes the asset's frame. NFD_ERROR_INVALID_ARGUMENT for NULL arguments or a non-zero
 * struct_size below this layout. */
NFD_API nfd_result nfd_asset_get_frame(const nfd_asset* asset, nfd_asset_frame* out_frame);

/* Evaluates the field at `count` points given in the ORIGINAL frame (xyz interleaved, 3*count
 * floats), writing `count` distances in the unit frame (multiply by info.scale for original
 * units). Runs on the context's device. count == 0 succeeds without touching the pointers;
 * otherwise NULL points/out_values give NFD_ERROR_INVALID_ARGUMENT. Memory used inside is bounded
 * (points are processed in blocks), whatever `count` is. The field as the network computes it,
 * not bounded by the shape's ball (nfd_mesh_extract). */
NFD_API nfd_result nfd_asset_evaluate(nfd_context* context, const nfd_asset* asset, const float* points,
                              size_t count, float* out_values);

/* As nfd_asset_evaluate (out_values identical), and also the field's analytic gradient at each
 * point (the chain rule through the network in reverse mode, on the CPU as on Vulkan; not
 * finite differences; the two agree to f32 rounding): 3*count floats to
 * out_gradients, xyz interleaved. A distance over a position is dimensionless: this is the gradient
 * of the unit-frame distance with respect to the unit-frame position, and equally of the original-
 * frame distance (value * scale) with respect to the original-frame position. A true distance
 * field has gradient norm 1; a UDF's points away from the surface. Where the network's abs output
 * is not differentiable (y = 0) the derivative of y >= 0 is taken. Same argument rules, outcomes
 * and bounded memory as nfd_asset_evaluate; out_gradients NULL with count > 0 gives
 * NFD_ERROR_INVALID_ARGUMENT. */
NFD_API nfd_result nfd_asset_evaluate_gradient(nfd_context* context, const nfd_asset* asset,
                                       const float* points, size_t count, float* out_values,
                                       float* out_gradients);

/* ---------------------------------------------------------------------------------------------
 * Colour (0.4; format 1.1)
 *
 * A file may carry a colour field: a second small network, fitted on the surface the decoder
 * extracts from the geometry (FORMAT.md, "colr"), so it is meaningful on that surface only.
 * Where an asset has one (nfd_asset_info.has_colour), everything that emits geometry also emits
 * its colour, evaluated on the context's device at the emitted positions: mesh vertices
 * (nfd_mesh_get_colours: nfd_mesh_extract, nfd_extraction_step, queue jobs), grid voxels
 * (nfd_grid_get_colours), and the writers carry it (PLY red/green/blue, glTF COLOR_0, a VDB
 * "colour" grid). skip_colour in the options gives geometry only; a file without colour decodes
 * exactly as before. Recorded decodes (nfd_recording) are geometry only.
 * Colours are RGB floats in [0, 1]: the input's 8-bit values / 255 with no transfer function
 * applied (for usual inputs display-encoded sRGB; treat them as such). 8-bit writers round:
 * min(255, floor(255 c + 0.5)). A damaged network whose output is not a number gives 0 there.
 * Streaming: an asset taken when its geometry is ready has no colour yet; the stream's complete
 * asset (nfd_stream_take_complete_asset) has it, and nfd_mesh_evaluate_colours colours meshes
 * made before it arrived.
 * ------------------------------------------------------------------------------------------- */

/* The colour at `count` points in the ORIGINAL frame relative to the asset's offset (as the
 * library emits positions: nfd_asset_frame; xyz interleaved), 3*count floats RGB to
 * out_rgb. Same argument rules, outcomes and bounded memory as nfd_asset_evaluate, and
 * NFD_ERROR_NO_COLOUR when the asset has no colour field. */
NFD_API nfd_result nfd_asset_evaluate_colour(nfd_context* context, const nfd_asset* asset,
                                             const float* points, size_t count, float* out_rgb);

/* ---------------------------------------------------------------------------------------------
 * Streaming input: a file as its bytes arrive
 *
 * An nfd_stream verifies a file while it is being received (network, slow storage) and hands out
 * the asset as soon as the geometry chunk is complete, before the rest of the file (optional
 * chunks such as colour) has arrived. "Complete" includes the 64-bit frame of a geo-referenced
 * file, which directly follows the geometry: the asset is ready once the 8 bytes after the
 * geometry chunk show another chunk (or the file ends there), or that frame has arrived. The chunk framing makes this possible (FORMAT.md,
 * "Incremental reading"): the header announces file_size, and each chunk's length precedes its
 * payload.
 *
 *     nfd_stream* s;  nfd_stream_progress p;  nfd_asset* asset = NULL;
 *     nfd_stream_create(NULL, &s);
 *     while ((n = receive(buf, sizeof buf)) > 0) {
 *         if (nfd_stream_feed(s, buf, n, &p) != NFD_SUCCESS) break;          // damaged: stop
 *         if (!asset && (p.flags & NFD_STREAM_GEOMETRY_READY)) nfd_stream_take_asset(s, &asset);
 *     }
 *     r = nfd_stream_finish(s);   // NFD_SUCCESS: the whole file arrived and is valid
 *     nfd_stream_destroy(s);      // the asset taken lives on, owned by the caller
 *
 * Which result a stream gives. The stream checks the bytes in FORMAT.md's order as they arrive
 * and reports the first failure in byte order, from the nfd_stream_feed call whose bytes complete
 * the structure that fails (the 16-byte header; a chunk's 8-byte frame: tag, length; a chunk's
 * payload and CRC); a byte fed past file_size is NFD_ERROR_CORRUPT (trailing data), and
 * nfd_stream_finish on a file not yet complete is NFD_ERROR_TRUNCATED. Hence the final result
 * (the failing feed's, else finish's) equals nfd_asset_create's on the same bytes
 *   - for every input of exactly file_size bytes, valid or damaged,
 *   - for every input whose header is incomplete (under 16 bytes: TRUNCATED) or damaged,
 *   - for every prefix of a valid file (TRUNCATED) and every valid file followed by more bytes
 *     (CORRUPT).
 * It can differ only when the bytes are not file_size long AND a chunk within them fails:
 * nfd_asset_create, knowing the size up front, applies FORMAT.md's size rule first (TRUNCATED,
 * CORRUPT), whereas the stream has reported that chunk's failure before it could know the size.
 * Errors are sticky: after a failure every nfd_stream_feed, nfd_stream_finish and
 * nfd_stream_take_asset returns the same code. (NFD_ERROR_INVALID_ARGUMENT, the caller's mistake
 * and not the file's, leaves the stream as it was.)
 *
 * Memory: the stream holds at most the header or one chunk (FORMAT.md caps a chunk at
 * NFD_MAX_CHUNK_SIZE), never the whole file, and reserves a chunk's buffer only after its length
 * has been checked against that cap and against file_size; plus, from GEOM's end until the
 * complete asset is taken (or the stream destroyed), the decoded asset. Bytes that complete a
 * structure within
 * one nfd_stream_feed call are read in place, not copied; only a structure split across calls is
 * gathered. Feeding costs time linear in the bytes, whatever the piece sizes (1 byte at a time
 * included). Decoding the geometry allocates as nfd_asset_create does.
 *
 * Threads: a stream is used by one thread at a time (no function may run concurrently on the same
 * stream); different streams are independent. The asset taken is independent of the stream.
 * ------------------------------------------------------------------------------------------- */
typedef struct nfd_stream nfd_stream;

/* Zero-initialise and set struct_size (see "Option structs"). */
typedef struct nfd_stream_options {
    uint32_t struct_size; /* 0.2: sizeof(nfd_stream_options), or 0 */
    /* (0.9) The context that will decode this stream's asset, or NULL. When set, the feed that
     * brings GEOM's first ~40 bytes (the network's shape: frequencies, widths, output) while the
     * rest of the chunk is still to come starts compiling that shape's field pipelines on a
     * thread of the context, and returns without waiting for it: a decode of the asset created
     * later on this context (nfd_mesh_extract, nfd_extraction_create, ...) finds them built, or
     * waits only for the rest of the compile. On 2-core lavapipe that is 20-80 ms the first level
     * no longer waits for after its geometry arrives (bench/RESULTS.md, "Streaming decode").
     * Only a hint: the shape is read before the chunk's CRC can vouch for it, so a damaged one
     * costs at most a compile nobody uses; results and errors are those of a stream without it.
     * A CPU context, a GEOM that arrives whole in one feed, or a context already compiling 4
     * shapes ahead: nothing happens. The context must outlive the stream's feed calls (its
     * destruction waits for the compiles it is running). */
    nfd_context* prepare_context;
} nfd_stream_options;

/* Bits of nfd_stream_progress.flags. Once set, a bit stays set (also after a failure, for what was
 * verified before it, and after the asset is taken). */
#define NFD_STREAM_HEADER_READ 0x1u     /* the header is verified: file_size, format_* are known */
#define NFD_STREAM_GEOMETRY_READY 0x2u  /* GEOM (the first chunk) is verified and decoded, and
                                           with it the 64-bit frame of a file that has one (see
                                           above): the asset can be taken */
#define NFD_STREAM_COLOUR_SEEN 0x4u     /* a `colr` chunk is verified and decoded (0.4: before,
                                           verified only) */
#define NFD_STREAM_COMPLETE 0x8u        /* all file_size bytes are verified: finish will succeed */

typedef struct nfd_stream_progress {
    uint64_t bytes_consumed;  /* bytes taken from the feeds so far: all of them while the stream
                                 is healthy; after a failure, up to the end of the structure that
                                 failed (at most file_size: a trailing byte is not taken) */
    uint32_t file_size;       /* announced by the header; 0 before NFD_STREAM_HEADER_READ */
    uint32_t format_major, format_minor; /* of the file; 0 before NFD_STREAM_HEADER_READ */
    uint32_t chunks_complete; /* chunks verified, GEOM included: each is reported as its last byte
                                 (its CRC) arrives */
    uint32_t flags;           /* NFD_STREAM_* bits */
} nfd_stream_progress;

/* options may be NULL. Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT (out_stream NULL, or
 * options not readable, see "Option structs"); NFD_ERROR_OUT_OF_MEMORY. */
NFD_API nfd_result nfd_stream_create(const nfd_stream_options* options, nfd_stream** out_stream);
/* An asset taken from the stream is not affected. Accepts NULL. */
NFD_API void nfd_stream_destroy(nfd_stream* stream);

/* Hands the next `size` bytes of the file to the stream (any size, 0 included; bytes may be NULL
 * when size is 0). The bytes are not retained: the caller may reuse them on return. If
 * out_progress is not NULL it receives the stream's progress after this call, whatever the
 * outcome (when stream is non-NULL).
 * Outcomes: NFD_SUCCESS (the bytes are consistent with a valid file so far); the first failure
 * in byte order, NFD_ERROR_TRUNCATED / CORRUPT / UNSUPPORTED_VERSION / UNSUPPORTED_FEATURE (see
 * "Which result a stream gives"; sticky); NFD_ERROR_INVALID_ARGUMENT (stream NULL, or bytes NULL
 * with size > 0; the stream is unchanged); NFD_ERROR_OUT_OF_MEMORY (sticky: the stream is then
 * unusable). */
NFD_API nfd_result nfd_stream_feed(nfd_stream* stream, const void* bytes, size_t size,
                                   nfd_stream_progress* out_progress);

/* Says that no more bytes will come. NFD_SUCCESS if the file is complete and valid (every byte
 * verified, exactly file_size of them); NFD_ERROR_TRUNCATED if it is not complete; the earlier
 * failure if there was one. Sticky like feed's failures; calling it again returns the same. A feed
 * of more bytes after a successful finish is trailing data (NFD_ERROR_CORRUPT).
 * NFD_ERROR_INVALID_ARGUMENT for NULL. */
NFD_API nfd_result nfd_stream_finish(nfd_stream* stream);

/* Gives the asset to the caller, once, as soon as NFD_STREAM_GEOMETRY_READY is set: the caller
 * owns it (nfd_asset_destroy) and may use it on any thread while the stream goes on receiving.
 * Why a new asset and not a borrowed pointer: an asset is immutable and shared across threads, so
 * the stream must not change it after handing it out, and it must be able to outlive the stream.
 * The asset is the file's geometry, bit for bit the one nfd_asset_create gives (same meshes and
 * values); nfd_asset_get_info reports the header's version and file_size, and has_colour as of the
 * moment it was taken (a `colr` chunk arriving later is reported by NFD_STREAM_COLOUR_SEEN). Taken
 * before the stream completes, it is geometry verified by its CRC and every GEOM rule, in a file
 * whose later bytes may still fail: only a stream that finishes with NFD_SUCCESS has passed every
 * check of nfd_asset_create.
 * Outcomes: NFD_SUCCESS (*out_asset set); the stream's failure if it has failed (even when GEOM
 * was verified before it; an asset taken earlier stays valid); NFD_ERROR_INVALID_ARGUMENT (NULL
 * argument, geometry not yet ready, the asset already taken, or the complete asset taken);
 * NFD_ERROR_OUT_OF_MEMORY. *out_asset is NULL on every failure. */
NFD_API nfd_result nfd_stream_take_asset(nfd_stream* stream, nfd_asset** out_asset);

/* (0.4) The whole file's asset, colour included, once NFD_STREAM_COMPLETE is set (every byte
 * verified): equal to nfd_asset_create's on the same bytes. Available once, whether or not the
 * geometry's asset was taken before (the stream keeps the decoded geometry until then: a few MB
 * at most); nfd_stream_take_asset is refused after it.
 * Outcomes: NFD_SUCCESS (*out_asset set); the stream's failure; NFD_ERROR_INVALID_ARGUMENT (NULL
 * argument, the file not complete, or already taken); NFD_ERROR_OUT_OF_MEMORY. *out_asset is NULL
 * on every failure. */
NFD_API nfd_result nfd_stream_take_complete_asset(nfd_stream* stream, nfd_asset** out_asset);

/* The format version of a file from its first 16 bytes, without parsing the rest: the checks that
 * every major keeps (FORMAT.md "Version policy"), in FORMAT.md's order. For a file from another
 * major this succeeds, so a caller can tell "too new for this library" from "not an .nfc file".
 * Only bytes 0..15 are read; the file's other header rules (flags, file_size) are 1.x rules and
 * are left to nfd_asset_create / nfd_stream.
 * Outcomes: NFD_SUCCESS (*out_major, *out_minor set, whatever their values); NFD_ERROR_TRUNCATED
 * (size < 16); NFD_ERROR_CORRUPT (bad magic, then bad header CRC); NFD_ERROR_INVALID_ARGUMENT
 * (a NULL pointer). Writes the outputs only on success. Thread-safe. */
NFD_API nfd_result nfd_peek_format_version(const void* bytes, size_t size, uint32_t* out_major,
                                           uint32_t* out_minor);

/* ---------------------------------------------------------------------------------------------
 * Mesh extraction
 * ------------------------------------------------------------------------------------------- */
typedef struct nfd_mesh nfd_mesh;

/* Zero-initialise and set struct_size (see "Option structs"), then set what you need. */
typedef struct nfd_mesh_options {
    uint32_t struct_size; /* 0.2: sizeof(nfd_mesh_options), or 0 */
    uint32_t resolution; /* grid cells per axis over the unit cube; 0 = NFD_DEFAULT_RESOLUTION;
                            NFD_MIN_RESOLUTION..NFD_MAX_RESOLUTION, else LIMIT_EXCEEDED */
    int skip_colour;     /* 0.4: non-zero: geometry only, even when the asset has colour */
    /* 0.5: memory limits of one decode, 0 = none. The decode runs level by level and checks,
     * before each level allocates, the upper bound of what it then holds (its levels, the mesh,
     * the evaluator's scratch: the bounds the queue's budget uses) against them: a decode that
     * could exceed a limit stops with NFD_ERROR_LIMIT_EXCEEDED before allocating it, whatever the
     * file's field makes of the surface. Output triangles are bounded through it (28 bytes per
     * vertex, 12 per triangle). Host: heap bytes; device: Vulkan buffer memory (ignored on the
     * CPU path), each buffer's own bytes: buffers of up to 1 MiB share 8 MiB blocks of device
     * memory (0.13.9), so the driver may hold up to a block's free space more per kind of
     * memory (nfd_context_get_device_memory). The mesh is the one without limits, byte for byte.
     * Queue jobs honour them too (their job fails with that code), beside the queue's budget. */
    uint64_t max_host_bytes;
    uint64_t max_device_bytes;
    /* 0.11: non-zero: the field is sampled on the band around its surface (every child of every
     * cell whose corners change sign or come within its half-diagonal (UDF: twice that) of zero,
     * as nfd_grid_extract samples), as all decodes were before 0.11 (UDF: before 0.12). Zero (the
     * default): the CPU path samples only the cells the surface crosses, found level by level
     * from the coarser level's crossings, and (0.11.1, above the finest level) the cells where the
     * field hovers within half a cell of zero: about 2.5 times fewer field evaluations at 256-512,
     * the dense grid's mesh on the real shapes measured (bench/RESULTS.md, "0.11" and "0.11.1"),
     * though a component of the surface that no crossing above and no near-zero cell leads to is
     * missed; on fields that are no shape's distance field (random networks) it misses more.
     * (0.13.17) Above the finest level it also follows from the vertices within half a cell of
     * zero that no crossing led to, and (0.13.18) from those within 0.15 of a cell whether or
     * not: on 113 fits of real shapes at 256 and 512, 217 of 226 decodes give the band's cells,
     * and the rest miss 2-44 of 100k-570k (bench/RESULTS.md, "0.13.17", "0.13.18"), where the
     * Vulkan path, which samples an SDF's band, finds them. (0.13.19) A cell far from the surface
     * whose corners read the file's truncation d* is no small closed component to refine: 2.5%
     * fewer evaluations on average, up to 11% for fits at d* = 0.05, the same 226 meshes. A
     * UDF (0.12) likewise samples the cells that can carry a triangle, found from the coarser
     * level's cells that can: about half the evaluations, the band's mesh on the files measured
     * (bench/RESULTS.md, "0.12"). The Vulkan path samples the band, but for a UDF's finest level
     * (0.13): there it visits the cells that can carry a triangle within the band's cells of the
     * level above, 0.63-0.69 of the band's evaluations at 256, the band's mesh on every file
     * measured (bench/RESULTS.md, "0.13"); a non-zero sample_band keeps the band there too. */
    int sample_band;
} nfd_mesh_options;

typedef struct nfd_mesh_data {
    const float* positions;   /* 3 * vertex_count floats, original frame relative to the offset
                                 (nfd_mesh_get_offset; (0, 0, 0) but for geo-referenced files) */
    const float* normals;     /* 3 * vertex_count floats, unit length, outward (UDF: see below) */
    const uint32_t* indices;  /* 3 * triangle_count, counter-clockwise seen from outside */
    size_t vertex_count;
    size_t triangle_count;
} nfd_mesh_data;

typedef struct nfd_decode_stats {
    double seconds_field;      /* coarse-to-fine field evaluation */
    double seconds_mesh;       /* marching cubes, welding, normals */
    uint64_t points_evaluated; /* field evaluations over all refinement levels */
    uint64_t active_cells;     /* finest-level cells that produced triangles */
} nfd_decode_stats;

/* Extracts the surface of an asset with sparse coarse-to-fine evaluation: an indexed, welded mesh
 * in original coordinates. SDF: marching cubes of the zero level set; closed where the field is,
 * consistently wound, normals outward. UDF (open surfaces, point clouds): MeshUDF-style pseudo-
 * signed marching cubes from the field's gradients; the surface may be open, and as an unsigned
 * field has no inside, winding and normals agree with each other but are not globally oriented.
 * Only the surface within 2 d* of the unit ball is extracted (FORMAT.md, "The shape's ball": the
 * shape lies in it; since 0.13.18), as for every output gridded from the field (levels, points,
 * grids). options may be NULL. An empty mesh (field without a surface) is a success. */
NFD_API nfd_result nfd_mesh_extract(nfd_context* context, const nfd_asset* asset,
                            const nfd_mesh_options* options, nfd_mesh** out_mesh);
NFD_API void nfd_mesh_destroy(nfd_mesh* mesh);

/* Pointers stay valid until nfd_mesh_destroy. */
NFD_API nfd_result nfd_mesh_get_data(const nfd_mesh* mesh, nfd_mesh_data* out_data);
/* (0.4) The vertices' colours, 3 * vertex_count floats RGB in [0, 1] (see "Colour"), or NULL when
 * the mesh has none (the asset has no colour, or skip_colour). Valid until nfd_mesh_destroy or
 * nfd_mesh_evaluate_colours. NFD_ERROR_INVALID_ARGUMENT for NULL arguments. */
NFD_API nfd_result nfd_mesh_get_colours(const nfd_mesh* mesh, const float** out_colours);
/* (0.4) Colours the mesh's vertices with the asset's colour field on the context's device,
 * replacing any colours it had: for meshes made from an asset without colour yet (streaming).
 * The asset should be the mesh's own file (its colour is fitted on that surface).
 * Outcomes: NFD_SUCCESS; NFD_ERROR_NO_COLOUR; NFD_ERROR_INVALID_ARGUMENT (NULL);
 * NFD_ERROR_DEVICE, NFD_ERROR_OUT_OF_MEMORY (the mesh keeps its former colours). */
NFD_API nfd_result nfd_mesh_evaluate_colours(nfd_context* context, const nfd_asset* asset,
                                             nfd_mesh* mesh);
/* (0.5) The offset the mesh's positions are relative to, 3 doubles: original = offset + position
 * (see nfd_asset_frame). NFD_ERROR_INVALID_ARGUMENT for NULL arguments. */
NFD_API nfd_result nfd_mesh_get_offset(const nfd_mesh* mesh, double* out_offset);
/* Timings and counts of the extraction that produced this mesh. */
NFD_API nfd_result nfd_mesh_get_stats(const nfd_mesh* mesh, nfd_decode_stats* out_stats);

/* Samples `count` points uniformly by area on the mesh (deterministic for a seed on every
 * platform), writing 3*count floats to out_points (as the mesh's positions: relative to its
 * offset) and, if out_normals is not
 * NULL, 3*count floats of unit face normals. count == 0 succeeds and writes nothing. An empty mesh
 * with count > 0, or out_points NULL, gives NFD_ERROR_INVALID_ARGUMENT. */
NFD_API nfd_result nfd_mesh_sample_points(const nfd_mesh* mesh, size_t count, uint64_t seed,
                                  float* out_points, float* out_normals);

/* Writes the mesh as binary glTF 2.0 (.glb: one scene/node/mesh, POSITION with min/max, NORMAL,
 * COLOR_0 (float VEC3) when the mesh has colours, UNSIGNED_INT indices; an empty mesh gives an
 * empty scene; a non-zero offset is the node's translation, positions stay local) or binary
 * little-endian PLY (vertex float x,y,z,nx,ny,nz, then uchar red,green,blue when the mesh has
 * colours; face list uchar uint vertex_indices; with a non-zero offset x,y,z are double,
 * offset + position, exact).
 * NFD_ERROR_INVALID_ARGUMENT for NULL arguments, NFD_ERROR_IO if the file cannot be opened or
 * fully written, NFD_ERROR_LIMIT_EXCEEDED for a .glb past 4 GiB (the format's 32-bit length). */
NFD_API nfd_result nfd_mesh_write_glb(const nfd_mesh* mesh, const char* path);
NFD_API nfd_result nfd_mesh_write_ply(const nfd_mesh* mesh, const char* path);

/* Writes a point set (3*count floats, optional normals) as binary little-endian PLY. */
NFD_API nfd_result nfd_points_write_ply(const float* points, const float* normals, size_t count,
                                const char* path);
/* (0.4) As nfd_points_write_ply, with optional colours (3*count floats RGB in [0, 1], e.g. from
 * nfd_asset_evaluate_colour; NULL: none) written as uchar red,green,blue after the normals. */
NFD_API nfd_result nfd_points_write_coloured_ply(const float* points, const float* normals,
                                                 const float* colours, size_t count,
                                                 const char* path);
/* (0.5) As nfd_points_write_coloured_ply, the points relative to `offset` (3 doubles, e.g. the
 * mesh's nfd_mesh_get_offset; NULL or zero: none): a non-zero offset writes double x,y,z =
 * offset + point. */
NFD_API nfd_result nfd_points_write_placed_ply(const float* points, const float* normals,
                                               const float* colours, size_t count,
                                               const double* offset, const char* path);

/* ---------------------------------------------------------------------------------------------
 * Progressive extraction: a mesh per level of detail, coarse to fine
 *
 * nfd_mesh_extract samples the field coarse to fine and meshes the finest level. An extraction
 * runs the same sampling one level per nfd_extraction_step and can mesh each level on the way,
 * each level evaluating only the grid points its coarser level did not hold: a caller shows the
 * coarse mesh early, and stops (destroys the extraction) at any level.
 *
 * The ladder of a resolution r: the levels of its sampling, coarsest first, r / 2^k cells per axis
 * rounded up for k = K, K-1, ..., 0, where K is the largest with ceil(r / 2^K) >= 32 (0 under
 * 64). E.g. 256: 32, 64, 128, 256; 200: 50, 100, 200; 130: 33, 65, 130; 48: 48 alone. At most
 * NFD_MAX_LADDER_LEVELS levels.
 *
 * The meshes: the final level's mesh is byte-identical (positions, normals, indices) to
 * nfd_mesh_extract's at r on the same device kind. A level whose resolution r / 2^k is exact is
 * byte-identical to nfd_mesh_extract's at r / 2^k (256's 32, 64, 128; all of 200's), with two
 * exceptions. On the CPU path's SDFs a level above the finest also follows the surface from cells
 * and vertices near zero (nfd_mesh_options.sample_band above), which a decode at r / 2^k does
 * not do at its finest level, so the level may hold cells of a sliver that that decode misses;
 * then its triangles are that decode's and those cells' (closer to the dense grid's mesh). On
 * 113 fits of real shapes, 12 of the 226 levels at 64 and 128 of a 256 ladder (bench/RESULTS.md,
 * "0.13.18"). And on a field steeper than the keep rule's margin (no fit of a real shape
 * measured; hostile networks: tests/fuzz, fuzz_progressive), the coarsest level of a ladder of
 * several levels is sampled as the decode at r samples it: a probe twice as coarse goes first,
 * and the vertices inside a probe cell that changes no sign and whose corners all lie farther
 * from zero than its keep threshold (its half-diagonal; UDF: 1.5 times) are not evaluated,
 * where a decode at r / 2^k, whose only level it is, evaluates every vertex; the level then
 * holds that decode's triangles but those of a surface hidden in such a cell, and normals beside
 * one may differ. Both devices alike (before 0.13.20 the CPU path also meshed cells of a skipped
 * probe cell beside a kept one from the values the probe filled in). A level
 * where r / 2^k is rounded up (130's 33 and 65) is no decode's own: it is marching cubes on that
 * level's cells as sampled for r, with cells 2^k * 2 / r wide, its last cells reaching up to one
 * cell past the unit cube. SDF and UDF alike; a UDF level's mesh needs the field's gradients at
 * the corners of its near cells, evaluated for that level (gradients_evaluated; those at corners
 * it shares with the level above, when that level was meshed, are copied from there, the same
 * count on every device kind), while the values of every level
 * are evaluated once: the points_evaluated of all steps add up to the one-shot decode's at r.
 * ------------------------------------------------------------------------------------------- */
typedef struct nfd_extraction nfd_extraction;

#define NFD_MAX_LADDER_LEVELS 8u

/* Writes the ladder of `resolution` (0 = NFD_DEFAULT_RESOLUTION), coarsest first, to
 * out_resolutions (capacity entries; may be NULL when capacity is 0) and its length to out_count.
 * Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT (out_count NULL, or capacity under the length
 * with out_resolutions written up to capacity); NFD_ERROR_LIMIT_EXCEEDED (resolution outside
 * NFD_MIN_RESOLUTION..NFD_MAX_RESOLUTION). Thread-safe. */
NFD_API nfd_result nfd_extraction_ladder(uint32_t resolution, uint32_t* out_resolutions,
                                         uint32_t capacity, uint32_t* out_count);

/* Zero-initialise and set struct_size (see "Option structs"), then set what you need. */
typedef struct nfd_extraction_options {
    uint32_t struct_size; /* 0.2: sizeof(nfd_extraction_options), or 0 */
    uint32_t resolution;  /* the final level, as nfd_mesh_options.resolution */
    uint32_t mesh_levels; /* bit i: mesh ladder level i (bit 0: the coarsest); 0 = every level.
                             Must include the final level; no bit past the ladder */
    int skip_colour;      /* 0.4: as nfd_mesh_options.skip_colour */
    int sample_band;      /* 0.11: as nfd_mesh_options.sample_band */
} nfd_extraction_options;

/* What a step did, and what the next one will allocate. */
typedef struct nfd_extraction_level {
    uint32_t struct_size;         /* set by the caller (sizeof, or 0 for the 0.2 layout): the
                                     library writes the fields it covers */
    uint32_t resolution;          /* cells per axis of the level just completed */
    uint32_t index;               /* its place in the ladder, 0 = coarsest */
    int done;                     /* non-zero: it was the final level */
    uint64_t points_evaluated;    /* field values evaluated by this step (new points only) */
    uint64_t gradients_evaluated; /* gradients this step's mesh needs of its own (UDF meshes):
                                     the corners of its near cells, but those it copies from the
                                     level above; the same on every device kind (both evaluate
                                     likely corners with their gradients as they first reach
                                     them, so they may compute more) */
    /* Upper bounds of the bytes the NEXT step allocates at its peak, above what is allocated when
     * it starts (the mesh it returns included), from what this step found (the cells it kept):
     * host memory, and device memory on a Vulkan context (0 on the CPU). 0 when done. Worst-case
     * bounds, not estimates: the next level's vertices are bounded by its kept parents' child
     * grids and its mesh as if every grid edge crossed the surface, so they exceed the real peak
     * several times (a job meshing every level of the golden bunny and T-shirt at 256,
     * tests/cpp/test_memory_bound.cpp: host on the CPU 4x-7x and 5x-10x up to 128, 14x and 17x
     * at 256; device on lavapipe 16x-21x). */
    uint64_t next_host_bytes;
    uint64_t next_device_bytes;
} nfd_extraction_level;

/* Prepares a progressive extraction of `asset` on `context`; evaluates nothing yet.
 * The extraction borrows both: they must outlive it, and the context must not be used by another
 * call (this extraction's, another's, any nfd_* call taking it) while a step runs. One thread at a
 * time may call an extraction; different threads may call it one after the other.
 * On a Vulkan context the network is uploaded here and its field pipelines start compiling on a
 * thread of the context; the first step evaluates the coarsest level with the C++ evaluator
 * meanwhile (it needs none of them: a first level is not held up by a slow first compile), and
 * the second waits for them if they are not ready.
 * Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT (NULL argument, mesh_levels without the final
 * level or with a bit past the ladder: a level not on the ladder); NFD_ERROR_LIMIT_EXCEEDED
 * (resolution outside the caps); NFD_ERROR_UNSUPPORTED_FEATURE (Vulkan: a network beyond the
 * shaders' caps, as nfd_mesh_extract); NFD_ERROR_DEVICE; NFD_ERROR_OUT_OF_MEMORY. */
NFD_API nfd_result nfd_extraction_create(nfd_context* context, const nfd_asset* asset,
                                         const nfd_extraction_options* options,
                                         nfd_extraction** out_extraction);

/* Does the next level's work, bounded by that level: evaluates its new points, and, if the level
 * is in mesh_levels, meshes it into *out_mesh (the caller's to destroy; NULL otherwise). In the
 * mesh's nfd_decode_stats, points_evaluated and seconds_field count all steps so far (on the final
 * level, points_evaluated is the one-shot decode's); active_cells and seconds_mesh are the level's.
 * out_info (may be NULL) receives what the step did.
 * Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT (extraction or out_mesh NULL, out_info's
 * struct_size below its first layout, a step after the final level or after a failed step);
 * NFD_ERROR_OUT_OF_MEMORY, NFD_ERROR_DEVICE, NFD_ERROR_LIMIT_EXCEEDED (a level beyond what the
 * device path can mesh): the extraction then only accepts destroy. */
NFD_API nfd_result nfd_extraction_step(nfd_extraction* extraction, nfd_mesh** out_mesh,
                                       nfd_extraction_level* out_info);

/* Stops wherever it is and frees everything; NULL is accepted. */
NFD_API void nfd_extraction_destroy(nfd_extraction* extraction);

/* ---------------------------------------------------------------------------------------------
 * Sparse grid: the field on a narrow band around the surface
 *
 * The coarse-to-fine sampling that meshes are extracted from, as a product of its own: the
 * distances at the grid vertices near the surface, for engines that build their own sparse volume
 * (bricks, a hash grid, an OpenVDB tree), or written as an OpenVDB file.
 * ------------------------------------------------------------------------------------------- */
typedef struct nfd_grid nfd_grid;

/* Zero-initialise and set struct_size (see "Option structs"), then set what you need. */
typedef struct nfd_grid_options {
    uint32_t struct_size; /* 0.2: sizeof(nfd_grid_options), or 0 */
    uint32_t resolution; /* grid cells per axis over the unit cube, as in nfd_mesh_options */
    int skip_colour;     /* 0.4: as nfd_mesh_options.skip_colour */
    uint64_t max_host_bytes; /* 0.5: as nfd_mesh_options.max_host_bytes (the grid's voxels, 16
                                bytes each, counted): 0 = none, else LIMIT_EXCEEDED beyond it */
} nfd_grid_options;

/* The voxels of a grid's finest level. A voxel is a grid vertex (a point sample, as in OpenVDB)
 * with integer indices 0..resolution on each axis; voxel n lies in the original frame at
 *     (ijk[3n], ijk[3n + 1], ijk[3n + 2]) * voxel_size + origin   (+ nfd_grid_get_offset),
 * where voxel_size = 2 * scale / resolution and origin = center - scale (the unit cube's corner
 * (-1, -1, -1)), scale and center those of nfd_asset_info; for a file with a 64-bit frame (see
 * nfd_asset_frame) origin = -scale and the offset holds the center.
 * The band: the corners of the finest cells that refinement visited (the children of the coarser
 * cells that may hold the surface), several cells deep on each side of it (the bunny at 256: up
 * to 8; 6% of the dense grid's vertices). A resolution too low to refine (under 63) keeps the
 * whole grid: (resolution + 1)^3 voxels.
 * Order: by blocks of 8x8x8 indices starting at multiples of 8 (OpenVDB's leaf nodes), blocks in
 * raster order (x fastest), then the voxels of a block in raster order. */
typedef struct nfd_grid_voxels {
    const int32_t* ijk;        /* 3 * count indices, xyz interleaved */
    const float* values;       /* count distances in original units: nfd_asset_evaluate at the
                                  voxel's position * scale; SDF negative inside, UDF >= 0 */
    size_t count;
    float voxel_size;          /* original units per index step */
    float origin[3];           /* original position of index (0, 0, 0) */
    float background;          /* truncation * scale: the distance the field was truncated at in
                                  training, to assume off the band (its negative inside an SDF) */
    uint32_t resolution;       /* cells per axis */
    nfd_field_type field_type;
} nfd_grid_voxels;

/* Samples the field coarse-to-fine with the levels of nfd_mesh_extract and its keep rule (a cell
 * is refined when its corners change sign or come within its half-diagonal of zero, twice that
 * for a UDF), and keeps the finest level; SDF and UDF assets alike. (Since 0.11 an SDF mesh on
 * the CPU samples fewer points: only the cells the surface crosses, not the band.) options may be NULL. The grid refers to neither the
 * context nor the asset: both may be destroyed first. In this version the grid is computed on the
 * CPU (the context's cpu_threads), whatever the context's device. The grid keeps 16 bytes per
 * voxel: memory follows the band, not resolution^3.
 * Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT (context, asset or out_grid NULL);
 * NFD_ERROR_LIMIT_EXCEEDED (resolution outside NFD_MIN_RESOLUTION..NFD_MAX_RESOLUTION);
 * NFD_ERROR_OUT_OF_MEMORY. */
NFD_API nfd_result nfd_grid_extract(nfd_context* context, const nfd_asset* asset,
                            const nfd_grid_options* options, nfd_grid** out_grid);
NFD_API void nfd_grid_destroy(nfd_grid* grid);

/* Pointers stay valid until nfd_grid_destroy. NFD_ERROR_INVALID_ARGUMENT for NULL arguments. */
NFD_API nfd_result nfd_grid_get_voxels(const nfd_grid* grid, nfd_grid_voxels* out_voxels);
/* (0.5) The offset of the grid's positions, 3 doubles (see nfd_asset_frame): original = offset +
 * ijk * voxel_size + origin. NFD_ERROR_INVALID_ARGUMENT for NULL arguments. */
NFD_API nfd_result nfd_grid_get_offset(const nfd_grid* grid, double* out_offset);
/* (0.4) The voxels' colours, 3 * count floats RGB in [0, 1] in the voxels' order (the colour at
 * each voxel's position; see "Colour"), or NULL when the grid has none. Valid until
 * nfd_grid_destroy. NFD_ERROR_INVALID_ARGUMENT for NULL arguments. */
NFD_API nfd_result nfd_grid_get_colours(const nfd_grid* grid, const float** out_colours);

/* Writes the voxels as an OpenVDB file holding one openvdb::FloatGrid named "distance": the voxels
 * active with their values (full float precision), the linear transform index -> original frame
 * above (in double, the offset included), background value `background`.
 *   SDF: grid class level set. Inactive voxels and tiles inside the surface read -background
 *        (OpenVDB's signed flood fill), so every read has the sign of inside/outside.
 *   UDF: grid class unknown, holding an unsigned distance: >= 0 everywhere, +background off the
 *        band.
 * Grid metadata: nfc_source_file (source_name; absent when NULL), nfc_field_type ("sdf" or
 * "udf"), nfc_format_version (the .nfc file's, e.g. "1.0"), nfc_resolution (int32), nfc_decoder
 * ("libnfdecode MAJOR.MINOR.PATCH").
 * A grid with colours (0.4) adds an openvdb::Vec3SGrid named "colour" with the same transform and
 * active voxels, holding RGB in [0, 1] (see "Colour"), background (0, 0, 0), class unknown.
 * The writer is a module of its own (0.8), libnfdecode_vdb.so, installed beside the library and
 * loaded on the first call, so that OpenVDB and its dependencies load only in processes that
 * write .vdb files. It is looked for at $NFD_VDB_MODULE (a path) if set; else beside the binary
 * holding libnfdecode (the shared library, or the executable a static one is linked into), in
 * ../lib (the install's libdir) from there, in the configured install libdir, then by name on
 * the dynamic loader's search path (LD_LIBRARY_PATH). It stays loaded for the process.
 * Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT (grid or path NULL);
 * NFD_ERROR_UNSUPPORTED_FEATURE in a build without OpenVDB (CMake NFD_WITH_OPENVDB=OFF), or when
 * the module is not found or is from another libnfdecode version, before the file is touched; NFD_ERROR_LIMIT_EXCEEDED (0.4), before the file is touched, for a transform
 * OpenVDB cannot hold: a voxel size under 1.45e-5 in the file's units (OpenVDB refuses a voxel
 * volume under 3e-15), or an origin more than 2^52 voxel sizes from zero (decode at a lower
 * resolution, or encode in larger units); NFD_ERROR_IO if the file cannot be created or fully
 * written; NFD_ERROR_OUT_OF_MEMORY. */
NFD_API nfd_result nfd_grid_write_vdb(const nfd_grid* grid, const char* path, const char* source_name);


/* ---------------------------------------------------------------------------------------------
 * Asynchronous queue: decodes on worker threads, the caller's thread only submits and polls
 *
 *     nfd_queue* q;  nfd_queue_options qo = {0};  qo.host_budget_bytes = 512u << 20;
 *     nfd_queue_create(ctx, &qo, &q);
 *     nfd_job* job;  nfd_queue_submit(q, asset, &mesh_options, NULL, &job);
 *     ... every frame: if (nfd_job_poll(job) == NFD_JOB_DONE) nfd_job_take_mesh(job, &mesh);
 *     nfd_job_destroy(job);  nfd_queue_destroy(q);
 *
 * A queue owns worker threads that run jobs on the context given at creation. A job is the
 * progressive extraction of an asset (see "Progressive extraction"): one step per ladder level,
 * coarsest first; between steps it checks for cancellation and for memory. The levels in the job's
 * mesh_levels are meshed and delivered as they complete (0: only the final level): each is
 * byte-identical to nfd_extraction_step's on the same context (so the final one to
 * nfd_mesh_extract's at the job's resolution, and an exact level to nfd_mesh_extract's at its
 * own). A job keeps the newest delivered mesh until taken: a newer level replaces (frees) an
 * untaken older one.
 *
 * Order: the pending job of highest priority starts first, jobs of equal priority in submission
 * order. The head of that order waits for memory rather than letting a later job overtake it, so
 * a large job is never starved by small ones.
 *
 * Memory budget: before a step runs, the queue reserves an upper bound of what the job holds
 * during the step (host and device bytes, nfd_queue_stats), and keeps it until the next step's
 * replaces it; everything is released when the job ends. The sum of reservations never exceeds
 * the budget. The bound of a step is what the job may hold when the step starts (the previous
 * step's reservation: the grid levels kept, the meshes made, the network copy) plus the bound of
 * what the step allocates: for the first step (it creates the extraction and evaluates the
 * coarsest level, 32 to 63 cells per axis) a measured bound (CPU host 32 MiB + 3 KiB * c^2 at c
 * cells; Vulkan host 64 MiB + 1 KiB * c^2, a driver compiling a network's pipelines takes tens of
 * MB, device 16 MiB + 1.5 KiB * c^2: libnfdecode/src/extract_work.cpp states how it was measured),
 * then nfd_extraction_level's next_host_bytes / next_device_bytes: worst-case bounds, several
 * times the real peak (see there). A job's reservation thus grows level by level, to about 4/3 of
 * its final level's bound. A mesh the job delivered counts while the job runs; once the job is
 * final, the mesh is the caller's and uncounted (collecting it late must not stall other jobs).
 *   A job whose first step does not fit waits (NFD_JOB_WAITING_FOR_MEMORY) until running jobs
 * release memory. A running job whose next step does not fit waits on its worker (its status
 * stays RUNNING), and while one does, no pending job starts: memory that is released goes first
 * to the jobs that hold some. When every running job waits so and none fits, the last of them in
 * the queue's order restarts: it releases everything, goes back to pending at its place
 * (QUEUED), and later evaluates its levels again, delivering none twice. So two jobs that each
 * fit the budget but not together both finish, one after the other. A step larger than the
 * whole budget can never fit: its job fails with NFD_ERROR_LIMIT_EXCEEDED instead of waiting
 * forever. A queue of one worker never restarts a job.
 *
 * Streaming: an engine feeds each arriving file to its own nfd_stream on its own thread (the cost
 * of nfd_stream_feed follows the bytes fed; the feed that completes the GEOM chunk decodes it),
 * takes the asset with nfd_stream_take_asset once NFD_STREAM_GEOMETRY_READY is set, submits it,
 * and may destroy the asset at once; bench/queue_frame.cpp does this in a frame loop and measures
 * the frame thread's time in these calls. Or (0.6) it submits the stream itself, before any byte
 * has arrived, and feeds the job: see nfd_queue_submit_stream.
 *
 * Threads: every queue and job function may be called from any thread, concurrently, except
 * that a destroy must not race with other calls on the same handle (nfd_queue_destroy with the
 * queue's own callbacks excepted: it refuses their submissions). None of them waits for work in
 * progress (they take a short internal lock that is never held while a step or a callback runs),
 * except nfd_job_wait (by design), nfd_queue_destroy (joins the workers, so it waits for steps in
 * progress), and nfd_job_destroy while that job's callback is running on another thread (it
 * waits for the callback to return).
 *
 * Scheduling (0.13.12): on Linux the threads the library starts for compute work (queue workers,
 * the CPU path's worker threads, the threads that compile pipelines ahead of a level) run under
 * SCHED_BATCH. Their share of the CPU is unchanged, but a worker that wakes (a job submitted, a
 * parallel pass starting) never preempts the thread running on its core: a render loop that
 * submits and polls keeps its frame while the decodes it starts take the idle time
 * (bench/RESULTS.md, "Workers that do not preempt"). Callbacks run on the workers, under that
 * policy. Where it is unavailable (other systems, a sandbox that refuses it) they run as started.
 * ------------------------------------------------------------------------------------------- */
typedef struct nfd_queue nfd_queue;
typedef struct nfd_job nfd_job;

typedef enum nfd_job_status {
    NFD_JOB_QUEUED = 0,             /* waiting for a worker, by priority */
    NFD_JOB_WAITING_FOR_MEMORY = 1, /* first in line; its next step does not fit the budget yet */
    NFD_JOB_RUNNING = 2,            /* a worker runs its steps (or it waits to grow, see above);
                                       a coarser level's mesh may be ready (nfd_job_take_mesh) */
    NFD_JOB_DONE = 3,               /* final: the final level's mesh is ready (nfd_job_take_mesh) */
    NFD_JOB_FAILED = 4,             /* final: nfd_job_take_mesh gives the error */
    NFD_JOB_CANCELLED = 5,          /* final: cancelled before it finished */
    NFD_JOB_WAITING_FOR_INPUT = 6   /* (0.6) a job of nfd_queue_submit_stream whose asset has not
                                       arrived yet; QUEUED once it has */
} nfd_job_status;

/* Zero-initialise and set struct_size (see "Option structs"), then set what you need. */
typedef struct nfd_queue_options {
    uint32_t struct_size;       /* 0.2: sizeof(nfd_queue_options), or 0 */
    uint32_t worker_threads;    /* jobs that run at once; 0 = 1. CPU jobs each use the context's
                                   cpu_threads; Vulkan jobs each record and submit batches of their
                                   own (0.3; 0.2 ran them one at a time), their submissions taking
                                   the queue in turn. */
    uint64_t host_budget_bytes;   /* 0 = unlimited */
    uint64_t device_budget_bytes; /* Vulkan buffer memory; 0 = unlimited */
} nfd_queue_options;

/* Called once per job when it reaches a final status (DONE, FAILED or CANCELLED), unless
 * nfd_job_destroy came first, and with NFD_JOB_RUNNING each time the job delivers the mesh of a
 * level before the final one (a mesh is then ready for nfd_job_take_mesh, unless a newer one
 * replaced it; the final level's delivery is the DONE call alone). Calls for one job never
 * overlap, come in the order of the levels, and the final one is the last. It runs on a worker
 * thread, or for a job cancelled before it started on the thread that cancelled it (nfd_job_cancel,
 * nfd_queue_destroy), or for a stream job whose input failed before it started on the thread
 * that fed it (nfd_job_feed, nfd_job_finish_input, nfd_queue_submit_stream). It may call nfd_job_poll, nfd_job_get_progress,
 * nfd_job_take_mesh, nfd_job_cancel, nfd_job_destroy (this job's included), nfd_queue_submit,
 * nfd_queue_get_stats, and any function outside the queue that is safe on that thread (not the
 * queue's context: the workers use it). It must not call nfd_job_wait or nfd_queue_destroy (a
 * worker would wait for itself). It should return quickly: the worker runs no job meanwhile. */
typedef void (*nfd_job_callback)(nfd_job* job, nfd_job_status status, void* user_data);

/* Zero-initialise and set struct_size (see "Option structs"), then set what you need. */
typedef struct nfd_job_options {
    uint32_t struct_size;      /* 0.2: sizeof(nfd_job_options), or 0 */
    int32_t priority;          /* higher starts first; default 0 */
    nfd_job_callback callback; /* NULL: none */
    void* user_data;           /* passed to callback */
    /* appended after 0.2 (read when struct_size covers it): */
    uint32_t mesh_levels;      /* the ladder levels to mesh and deliver, as
                                  nfd_extraction_options.mesh_levels (bit i: ladder level i, 0 =
                                  coarsest; must include the final level; no bit past the
                                  ladder), except that 0 = the final level only (the 0.2 job) */
} nfd_job_options;

/* Where a job is (nfd_job_get_progress). */
typedef struct nfd_job_progress {
    uint32_t struct_size;            /* set by the caller (sizeof, or 0 for the first layout): the
                                        library writes the fields it covers */
    uint32_t levels_done;            /* ladder levels evaluated, 0..levels_total (a restarted job
                                        keeps its count while it evaluates them again) */
    uint32_t levels_total;           /* the ladder's length at the job's resolution */
    uint32_t newest_mesh_resolution; /* cells per axis of the newest delivered mesh, taken or
                                        not; 0 before the first */
    uint32_t taken_mesh_resolution;  /* that of the mesh the last successful nfd_job_take_mesh
                                        gave; 0 before */
    uint32_t final_resolution;       /* the job's resolution: the last level's */
} nfd_job_progress;

typedef struct nfd_queue_stats {
    uint64_t jobs_submitted, jobs_done, jobs_failed, jobs_cancelled;
    uint64_t reserved_host_bytes, reserved_device_bytes;           /* now */
    uint64_t peak_reserved_host_bytes, peak_reserved_device_bytes; /* since creation */
} nfd_queue_stats;

/* Starts the workers. The context must outlive the queue, and nothing else may use it while the
 * queue exists (the workers do; one queue per context). options may be NULL (one worker, no
 * budget). Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT (context or out_queue NULL, bad
 * struct_size); NFD_ERROR_OUT_OF_MEMORY (also when a thread cannot be started). */
NFD_API nfd_result nfd_queue_create(nfd_context* context, const nfd_queue_options* options,
                                    nfd_queue** out_queue);
/* Cancels every job that has not finished (pending ones at once, their callbacks on this thread;
 * running ones at their next step boundary), waits for the workers and joins them. Job handles
 * stay valid (final, CANCELLED unless they finished first) until nfd_job_destroy. NULL is a
 * no-op. Must not be called from a callback. */
NFD_API void nfd_queue_destroy(nfd_queue* queue);

/* Queues the extraction of `asset` with mesh `options` (as nfd_mesh_extract; NULL = defaults) and
 * job `options` (NULL = defaults). The queue keeps its own copy of the asset's network: the asset
 * may be destroyed as soon as this returns. Never waits for work in progress; O(log n) in the
 * pending jobs plus a copy of the network's weights (at most the NFD_MAX_PARAMETERS cap, 4 MiB).
 * Outcomes: NFD_SUCCESS and *out_job (release with nfd_job_destroy); NFD_ERROR_INVALID_ARGUMENT
 * (NULL queue, asset or out_job, bad struct_size, mesh_levels without the final level or with a
 * bit past the ladder of the resolution); NFD_ERROR_LIMIT_EXCEEDED (resolution outside
 * the caps); NFD_ERROR_CANCELLED (called from a callback while nfd_queue_destroy runs);
 * NFD_ERROR_OUT_OF_MEMORY. A job too large for the budget is accepted, then FAILED. */
NFD_API nfd_result nfd_queue_submit(nfd_queue* queue, const nfd_asset* asset,
                                    const nfd_mesh_options* mesh_options,
                                    const nfd_job_options* job_options, nfd_job** out_job);

/* (0.6) Queues the extraction of the file that `stream` is receiving, before it has arrived: the
 * job takes the stream over, the caller feeds it with nfd_job_feed and ends it with
 * nfd_job_finish_input, and the job starts as soon as the asset its mesh options need is there:
 *   - mesh_options->skip_colour set: once the geometry is ready (NFD_STREAM_GEOMETRY_READY, what
 *     nfd_stream_take_asset gives); the meshes have no colour;
 *   - otherwise: once the whole file is verified (NFD_STREAM_COMPLETE, nfd_stream_take_complete_
 *     asset's asset), so that its meshes are those of nfd_queue_submit on the complete asset,
 *     colours included. A file without colour is complete when its geometry is (GEOM is its
 *     last chunk).
 * Until then the job is NFD_JOB_WAITING_FOR_INPUT: it reserves no memory (the stream's buffer,
 * at most one chunk, is not counted in the budget) and holds no place among the pending jobs,
 * but its priority and submission order are fixed now. Then it is QUEUED and runs as any job; its
 * meshes are byte-identical to nfd_queue_submit's on the same asset. The stream may have been
 * fed already (not its asset taken: the job then fails with NFD_ERROR_INVALID_ARGUMENT); if what
 * it holds already suffices, the job is QUEUED at once.
 * Outcomes: as nfd_queue_submit (stream NULL: NFD_ERROR_INVALID_ARGUMENT). On NFD_SUCCESS the job
 * owns the stream (do not use or destroy it; nfd_job_destroy does); on failure the caller keeps
 * it. A stream that has failed gives a job that fails at once with the stream's error (its
 * callback runs on this thread before this returns). A stream without a prepare_context
 * (nfd_stream_options) takes the queue's context as its own (0.9). */
NFD_API nfd_result nfd_queue_submit_stream(nfd_queue* queue, nfd_stream* stream,
                                           const nfd_mesh_options* mesh_options,
                                           const nfd_job_options* job_options, nfd_job** out_job);

/* (0.6) Feeds the next bytes of a stream job's file: nfd_stream_feed on the job's stream, on the
 * calling thread (the feed that completes what the job waits for also makes it QUEUED: a copy of
 * the network's weights, no waiting). Calls on one job's input (this and nfd_job_finish_input)
 * are serialised by a lock of the job's own; bytes must come in file order.
 * Outcomes: as nfd_stream_feed, and out_progress likewise. A failure before the job started also
 * fails the job with that error (its callback on this thread); after it started, the job goes on
 * (its asset was complete and verified) and the failure is the caller's to act on: a file whose
 * later bytes are damaged. NFD_ERROR_CANCELLED, nothing fed, if the job was cancelled before it
 * started; NFD_ERROR_INVALID_ARGUMENT (NULL job, a job not made by nfd_queue_submit_stream,
 * bytes NULL with a size). */
NFD_API nfd_result nfd_job_feed(nfd_job* job, const void* bytes, size_t size,
                                nfd_stream_progress* out_progress);

/* (0.6) Says that no more bytes will come: nfd_stream_finish on the job's stream. A job still
 * waiting for input then fails with the result (NFD_ERROR_TRUNCATED for a file that ended early).
 * Outcomes: as nfd_stream_finish; NFD_ERROR_CANCELLED if the job was cancelled before it started;
 * NFD_ERROR_INVALID_ARGUMENT (NULL job, a job not made by nfd_queue_submit_stream). */
NFD_API nfd_result nfd_job_finish_input(nfd_job* job);

/* A snapshot of the counters. NFD_ERROR_INVALID_ARGUMENT for NULL arguments. */
NFD_API nfd_result nfd_queue_get_stats(const nfd_queue* queue, nfd_queue_stats* out_stats);

/* The job's status now. A job is final (DONE, FAILED, CANCELLED) to poll and wait once its
 * callback has returned: RUNNING until then. NULL gives NFD_JOB_FAILED. */
NFD_API nfd_job_status nfd_job_poll(const nfd_job* job);

/* Waits until the job is final (as nfd_job_poll sees it) or `timeout_ns` nanoseconds have passed
 * (0: do not wait; UINT64_MAX: no limit), and returns its status: final, or the status when the
 * time ran out. NULL gives NFD_JOB_FAILED. Must not be called from a callback. */
NFD_API nfd_job_status nfd_job_wait(nfd_job* job, uint64_t timeout_ns);

/* Cancels the job: a pending job becomes CANCELLED at once (its callback runs on this thread
 * before this returns); a running one when its current step (level) ends (the last one included:
 * its mesh is dropped, as is an untaken coarser one); a final one stays as it is. Everything the job allocated is freed when it becomes
 * CANCELLED. NFD_ERROR_INVALID_ARGUMENT for NULL, else NFD_SUCCESS. */
NFD_API nfd_result nfd_job_cancel(nfd_job* job);

/* Hands the job's newest delivered mesh to the caller, who destroys it with nfd_mesh_destroy; it
 * outlives the job and the queue. Which level it is: nfd_job_get_progress's
 * taken_mesh_resolution, set by this same call (the final level's once DONE).
 * Outcomes: NFD_SUCCESS and *out_mesh (a level's mesh while RUNNING, the final one when DONE;
 * once DONE and taken, NFD_SUCCESS and NULL); NFD_ERROR_NOT_READY (not final, no mesh ready);
 * NFD_ERROR_CANCELLED (an untaken mesh was freed with the job's memory); the job's error (FAILED:
 * what nfd_extraction_step would have returned, or NFD_ERROR_LIMIT_EXCEEDED for a step over the
 * whole budget); NFD_ERROR_INVALID_ARGUMENT (NULL arguments). *out_mesh is NULL unless a mesh is
 * given. */
NFD_API nfd_result nfd_job_take_mesh(nfd_job* job, nfd_mesh** out_mesh);

/* Writes the job's progress: the fields out_progress->struct_size covers (0: the first layout,
 * this one). NFD_ERROR_INVALID_ARGUMENT for NULL arguments or a struct_size below it. */
NFD_API nfd_result nfd_job_get_progress(const nfd_job* job, nfd_job_progress* out_progress);

/* Releases the handle in any status, cancelling the job if it has not finished (a running step
 * completes on its worker, which then frees it). No callback starts after this returns; if this
 * job's callback is running on another thread, this waits for it. An untaken mesh is destroyed.
 * NULL is a no-op. Legal before or after nfd_queue_destroy. */
NFD_API void nfd_job_destroy(nfd_job* job);

/* ---------------------------------------------------------------------------------------------
 * Recording into the host's command buffer (Vulkan contexts)
 *
 *     nfd_recording* rec;  nfd_recording_options ro = {0};  ro.struct_size = sizeof ro;
 *     nfd_recording_create(ctx, asset, &ro, &rec);         // ctx adopted the engine's device
 *     nfd_device_mesh dm;  nfd_recording_get_mesh(rec, &dm);
 *     nfd_recording_record(rec, cmd);                      // cmd: the engine's VkCommandBuffer
 *     ... the engine submits cmd; later, in a render pass of a cmd submitted after it:
 *     vkCmdBindVertexBuffers(... dm.positions ..., dm.normals ...);
 *     vkCmdBindIndexBuffer(... dm.indices, 0, VK_INDEX_TYPE_UINT32);
 *     vkCmdDrawIndexedIndirect(draw_cmd, dm.draw, 0, 1, 20);
 *     ... once the engine has waited for cmd (fence, timeline semaphore):
 *     nfd_recording_result res = {0};  res.struct_size = sizeof res;
 *     if (nfd_recording_finish(rec, &res) == NFD_ERROR_CAPACITY_EXCEEDED) record again with
 *         res.needed_* as the capacities;
 *     nfd_recording_destroy(rec);                          // after the wait; frees the buffers
 *
 * Instead of the library's own submission (nfd_mesh_extract, extractions, the queue), the whole
 * decode of a mesh is recorded into a command buffer of the engine's, which submits it with its
 * own work. The mesh stays on the device, in buffers the engine's graphics pipeline binds as they
 * are (zero copy), drawn through an indirect draw record the decode writes: no count makes a
 * round trip to the host. It is the same decode as nfd_mesh_extract's on the same context, level
 * by level and kernel by kernel: the mesh is byte-identical (nfd_recording_read_mesh).
 *
 * Capacities. Nothing is read back while the commands run, so every size is fixed when they are
 * recorded: the kept cells of each level of the sampling (max_cells: level 1's, the mesher's
 * parents at r/2 cells per axis; a coarser level l gets 2 * (max_cells / 4^(l-1) + 64), at most
 * its number of cells), the UDF's gradient points, the mesh's vertices and triangles. The buffers
 * are made to these sizes; the decode's scratch lives until nfd_recording_finish, the mesh
 * buffers until nfd_recording_destroy (about 260 bytes per cell of
 * max_cells, the coarser levels included, 16 per gradient point, 28 per vertex and 12 per
 * triangle, plus the levels' bitmaps, r^3 / 32 bytes at level 1). A decode whose totals exceed
 * them stops at the first total that does (every later kernel does nothing, nothing is written
 * out of bounds), its draw record draws nothing, and nfd_recording_finish says so and what would
 * have sufficed. The defaults (0) per (r / 64)^2: 16384 cells, 49152 gradient points, 16384
 * vertices and 32768 triangles, twice what typical assets need (about 95 MB at r = 256 for a UDF;
 * bench/recording.cpp measures the needs, bench/RESULTS.md "Recording into the host's command
 * buffer"); a very detailed asset (the Stanford dragon's UDF at 256: 38744 vertices per (r/64)^2)
 * takes a second try.
 *
 * What the engine must do. The context must have adopted the engine's device (nfd_context_options
 * .adopt); the command buffer is the engine's (a primary one, of a pool of the adopted queue
 * family, in the recording state, outside a render pass), and so is its submission, once. The
 * recorded commands are compute dispatches (direct and indirect) and buffer fills, ending with a
 * global memory barrier from COMPUTE_SHADER | TRANSFER writes to VERTEX_INPUT (vertex attribute
 * and index reads), DRAW_INDIRECT, VERTEX_SHADER, COMPUTE_SHADER, TRANSFER and HOST reads: work
 * recorded after them in the same command buffer, or in a later submission on the same queue,
 * may read the mesh buffers. A submission on another queue needs the engine's semaphore (and, for
 * another family, queue-family ownership is the engine's concern: the buffers are
 * VK_SHARING_MODE_EXCLUSIVE). finish and read_mesh need the engine's wait for that submission
 * to have returned; finish frees the scratch and descriptor sets, destroy the mesh buffers (after
 * the engine's last draw from them, or before any submission).
 *
 * Threads: a recording borrows its context and asset (both must outlive it); create, record,
 * finish, read_mesh and destroy use the context's device like any call taking it (finish and
 * read_mesh copy through a staging buffer on the context's queue where memory is not unified), so
 * they must not run concurrently with another call on the same context; get_mesh only reads.
 * ------------------------------------------------------------------------------------------- */
typedef struct nfd_recording nfd_recording;

/* Caps of a recording's capacities: cells below 2^26 (what the meshers address), the others at
 * most 2^28 (6 GB of vertices); above them nfd_recording_create gives NFD_ERROR_LIMIT_EXCEEDED. */
#define NFD_MAX_RECORDING_CELLS ((1u << 26) - 1u)
#define NFD_MAX_RECORDING_ITEMS (1u << 28)

/* Zero-initialise and set struct_size (see "Option structs"), then set what you need. */
typedef struct nfd_recording_options {
    uint32_t struct_size;         /* 0.3: sizeof(nfd_recording_options), or 0 */
    uint32_t resolution;          /* as nfd_mesh_options.resolution */
    uint32_t max_cells;           /* capacities, see above; 0 = the default of the resolution */
    uint32_t max_gradient_points; /* UDF fields (ignored for SDF) */
    uint32_t max_vertices;
    uint32_t max_triangles;
} nfd_recording_options;

/* The mesh's buffers on the engine's device: VkBuffer handles (cast with (VkBuffer)(uintptr_t) on
 * 64-bit platforms, where they are pointers), owned by the recording. Each allows STORAGE,
 * UNIFORM, TRANSFER_SRC/DST, VERTEX, INDEX and INDIRECT usage. Only the first vertex_count /
 * triangle_count entries (nfd_recording_result) are the mesh; the draw record covers exactly them. */
typedef struct nfd_device_mesh {
    uint64_t positions;       /* 3 floats per vertex, original frame relative to the asset's offset
                                 (nfd_asset_frame): a vertex buffer, stride 12 */
    uint64_t normals;         /* 3 floats per vertex, unit length (as nfd_mesh_data) */
    uint64_t indices;         /* 3 uint32 per triangle: VK_INDEX_TYPE_UINT32 */
    uint64_t draw;            /* one VkDrawIndexedIndirectCommand at offset 0 (20 bytes):
                                 indexCount = 3 * triangles (0 after an overflow), instanceCount 1,
                                 firstIndex, vertexOffset and firstInstance 0 */
    uint32_t vertex_capacity;   /* entries the buffers hold */
    uint32_t triangle_capacity;
} nfd_device_mesh;

typedef struct nfd_recording_result {
    uint32_t struct_size;       /* set by the caller (sizeof, or 0 for this layout) */
    uint32_t vertex_count;      /* the mesh (0 after an overflow) */
    uint32_t triangle_count;
    /* Capacities that would have held every total the decode counted: the ones given, raised
     * where a total exceeded them. Totals after the first overflow were not counted, so a decode
     * may need more than one more try, each raising at least one capacity; one above its cap
     * (NFD_MAX_RECORDING_*) means the decode cannot be recorded at this resolution. */
    uint32_t needed_cells, needed_gradient_points, needed_vertices, needed_triangles;
    nfd_decode_stats stats;     /* points_evaluated, active_cells; times are 0 (the engine's) */
} nfd_recording_result;

/* Makes the recording: uploads the network, starts compiling its pipelines (recording waits for
 * them), makes the mesh buffers; records nothing yet. Outcomes: NFD_SUCCESS;
 * NFD_ERROR_INVALID_ARGUMENT (NULL argument, a CPU context); NFD_ERROR_LIMIT_EXCEEDED (resolution
 * outside the caps, a capacity above its cap above); NFD_ERROR_UNSUPPORTED_FEATURE (a network
 * beyond the shaders' caps); NFD_ERROR_OUT_OF_MEMORY; NFD_ERROR_DEVICE. */
NFD_API nfd_result nfd_recording_create(nfd_context* context, const nfd_asset* asset,
                                        const nfd_recording_options* options,
                                        nfd_recording** out_recording);

/* The mesh buffers, valid from creation to destroy. NFD_ERROR_INVALID_ARGUMENT for NULL. */
NFD_API nfd_result nfd_recording_get_mesh(const nfd_recording* recording,
                                          nfd_device_mesh* out_mesh);

/* Records the decode into `command_buffer` (a VkCommandBuffer), once per recording; it makes the
 * levels' buffers as it goes (device memory). Outcomes: NFD_SUCCESS; NFD_ERROR_INVALID_ARGUMENT
 * (NULL argument, a second call); NFD_ERROR_OUT_OF_MEMORY, NFD_ERROR_DEVICE (the command buffer
 * then holds part of the decode: do not submit it). */
NFD_API nfd_result nfd_recording_record(nfd_recording* recording, void* command_buffer);

/* After the engine's wait for the recorded commands (never before: it frees the decode's scratch,
 * which those commands use): what they produced; a second call gives the same. The recording then
 * holds only the mesh buffers. Outcomes: NFD_SUCCESS; NFD_ERROR_CAPACITY_EXCEEDED (a total
 * exceeded its capacity: vertex and triangle counts are 0, needed_* say what to try next);
 * NFD_ERROR_INVALID_ARGUMENT (NULL argument, out_result's struct_size below its layout, not
 * recorded); NFD_ERROR_DEVICE (the read-back failed). */
NFD_API nfd_result nfd_recording_finish(nfd_recording* recording,
                                        nfd_recording_result* out_result);

/* A host copy of the mesh after a successful finish, the caller's to destroy (nfd_mesh_destroy);
 * its stats are the result's. NFD_ERROR_INVALID_ARGUMENT (NULL argument, not finished or
 * overflowed); NFD_ERROR_OUT_OF_MEMORY. */
NFD_API nfd_result nfd_recording_read_mesh(const nfd_recording* recording, nfd_mesh** out_mesh);

/* Frees the buffers and descriptor sets: after the engine's wait (see above). NULL is a no-op. */
NFD_API void nfd_recording_destroy(nfd_recording* recording);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* NFDECODE_NFDECODE_H */
