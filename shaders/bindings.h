// Binding numbers, local sizes, push-constant sizes and caps shared by the compute kernels
// (shaders/*.comp, *.glsl) and the host (libnfdecode/src/gpu/kernels.cpp, which declares each
// kernel once from these). Plain #defines, so that the GLSL and the C++ preprocessors both read
// this file; nothing else may be declared here.
#ifndef NFD_SHADERS_BINDINGS_H
#define NFD_SHADERS_BINDINGS_H

// ---- field_eval.comp (all four variants) --------------------------------------------------------
#define NFD_B_FIELD_POINTS 0       // xyz per point
#define NFD_B_FIELD_VALUES 1       // OUTPUTS floats per point, or (value, gradient) as a vec4
#define NFD_B_FIELD_FREQUENCIES 2  // uniform: NFD_GPU_MAX_FREQUENCIES / 4 vec4s
#define NFD_B_FIELD_LAYER0 3       // layer l's weights at binding NFD_B_FIELD_LAYER0 + l
#define NFD_GPU_MAX_LAYERS 8       // = NFD_MAX_LAYERS: one weight block per layer
#define NFD_GPU_MAX_FREQUENCIES 24 // = NFD_MAX_FREQUENCIES
#define NFD_GPU_MAX_WIDTH 512      // >= NFD_MAX_WIDTH: activations are sized for it
#define NFD_GPU_UNIFORM_VEC4S 4096 // a uniform weight block: 64 KiB
#define NFD_FIELD_LOCAL_SIZE 32
#define NFD_FIELD_LANES 8         // field_eval_lanes.comp's subgroup, its local size
#define NFD_FIELD_LOCAL_SIZE_ID 15 // constant_id of local_size_x (after the network and POINTS)
#define NFD_B_FIELD_COUNTERS 11    // the job's counters (counters.glsl)
#define NFD_FIELD_PUSH_BYTES 20    // capacity, the first result's index, the count's slot, the ball

// ---- scan.comp ----------------------------------------------------------------------------------
#define NFD_B_SCAN_IN 0
#define NFD_B_SCAN_OUT 1
#define NFD_B_SCAN_SUMS 2
#define NFD_SCAN_LOCAL_SIZE 256
#define NFD_SCAN_BLOCK 1024        // elements per workgroup: 4 per invocation
#define NFD_B_SCAN_COUNTERS 3      // bitmap_compact, count_total, dispatch_args: the counters
#define NFD_COUNT_PUSH_BYTES 4     // scan and bitmap_compact: the element count
#define NFD_TOTAL_PUSH_BYTES 16    // count_total.comp's TotalPush
#define NFD_B_ARGS 4               // dispatch_args.comp: VkDispatchIndirectCommand records
#define NFD_ARGS_PUSH_BYTES 20     // dispatch_args.comp's ArgsPush
#define NFD_DRAW_PUSH_BYTES 8      // draw_args.comp's DrawPush

// ---- the job's counters (counters.glsl) ---------------------------------------------------------
// Item counts that kernels produce and later kernels consume without a host read-back: slot 0
// is the overflow flag, NFD_NO_COUNTER means "the dispatch's capacity is its count".
#define NFD_COUNTER_OVERFLOW 0
#define NFD_NO_COUNTER 0xffffffffu
#define NFD_COUNTER_SLOTS 256

// ---- the sparse levels and meshers (extract.glsl, mc.glsl, udf.glsl) ---------------------------
// One number per buffer role across all of them, so that any kernel can bind any role.
// A level: its kept cells (extract.glsl).
#define NFD_B_KEPT_BITS 0          // bitmap over the level's cells
#define NFD_B_KEPT_PREFIX 1        // exclusive prefix of the bitmap words' popcounts
#define NFD_B_KEPT_CELLS 2         // sorted linear indices of the kept cells
#define NFD_B_CORNERS 3            // 8 values per kept cell
#define NFD_B_KEPT_AROUND 44       // per kept cell, which of its 27 neighbours are kept
                                   // (extract.glsl's kept_around, level_around.comp)
// A list of child-grid points, owned by kept parents (extract.glsl): the new points of a
// refinement (values), or the points that need a gradient (UDF).
#define NFD_B_OWNED 4              // per parent, 27-bit mask of its local points in the list
#define NFD_B_OFFSETS 5            // per parent, its first point's index in the list
#define NFD_B_VALUES 6             // field values of the new points
// 7: unused (refine_count's per-parent counts until 0.12.2; offsets scan the masks' popcounts)
#define NFD_B_POINTS 8             // unit-frame xyz of the listed points; dense_lookup:
                                   // their values (1 or 4 floats each)
#define NFD_B_CHILD_BITS 9         // the child level's kept bitmap
#define NFD_B_CHILD_CELLS 10       // the child level's sorted kept cells
#define NFD_B_CHILD_CORNERS 11     // their corner values
// Marching cubes over the children of the level-1 parents (mc.glsl).
#define NFD_B_MC_TABLES 12         // mc_tables.h, in mc.glsl's layout
#define NFD_B_CASES 13             // per parent, uvec4: cube case and emitted-triangle mask
                                   // of each child (8 bits each)
#define NFD_B_EMITTING 45          // per parent, which of its 8 children emit a triangle
#define NFD_B_EDGE_MASKS 14        // per parent, uvec2: the owned edges (of 54) with a vertex
#define NFD_B_TRIANGLE_COUNTS 15
// 16: unused (the count of cells that emitted a triangle until 0.13.15: the emitting masks' total)
#define NFD_B_VERTEX_OFFSETS 17    // per edge-mask word, exclusive prefix of popcounts
#define NFD_B_TRIANGLE_OFFSETS 18
#define NFD_B_VERTEX_EDGES 19      // per vertex, parent rank << 6 | edge id
#define NFD_B_INDICES 20
#define NFD_B_POSITIONS 21
#define NFD_B_NORMALS 22
// UDF (udf.glsl).
#define NFD_B_NEAR_MASKS 23        // per parent, which of its 8 children are near cells
#define NFD_B_GRADIENT_OWNED 24    // the gradient point list (NFD_B_OWNED's layout)
#define NFD_B_GRADIENT_OFFSETS 25
#define NFD_B_GRADIENTS 26         // (value, gradient) per listed point, field_eval's output
#define NFD_B_COUNTERS 27          // the job's counters (counters.glsl)
#define NFD_B_DENSE_VALUES 28      // dense_lookup: the coarsest level's values (side^3
                                   // vertices; 1 or 4 floats each), from the host
// Progressive UDF levels: a level's gradient list carried to the next finer level, whose parents
// are the level's kept cells and whose even child-grid points are those cells' corners.
#define NFD_B_CORNER_GRADIENTS 29  // per parent, 8 indices into the level above's list
#define NFD_B_ABOVE_GRADIENTS 30   // that list's (value, gradient) per point
#define NFD_B_FRESH_GRADIENTS 31   // (value, gradient) of the points the list above lacks
#define NFD_NOT_LISTED 0xffffffffu // a corner gradient the level above did not evaluate
// A meshed UDF level (the finest; in own jobs of progressive extractions, every meshed level):
// its new points that are likely corners of near cells (udf_predict.comp), evaluated with their
// gradients in the value pass, which the gradient list then copies. The level's value list
// (NFD_B_OWNED ...) holds the others.
#define NFD_B_PREDICTED_OWNED 32   // per parent, 27-bit mask (NFD_B_OWNED's layout)
#define NFD_B_PREDICTED_OFFSETS 33
#define NFD_B_PREDICTED 34         // (value, gradient) per point, field_eval's gradient output
// A UDF's finest level by surface following (udf_flood.comp), whose evaluated points are the
// predicted list's, in the slots of all owned points.
#define NFD_B_FLOOD_VISITED 35     // per parent, 8 bits: its children the flood visited
#define NFD_B_FLOOD_FRESH 36       // per parent: children first visited in the wave before
#define NFD_B_FLOOD_NEXT 37        // per parent: children first visited in this wave
#define NFD_B_FLOOD_CLAIMED 38     // per parent: its owned points claimed for evaluation;
                                   // bit 31: a seed came from its edges
#define NFD_B_FLOOD_POINTS 39      // claimed points in claim order: owner rank << 5 | local
#define NFD_B_FLOOD_FRONTIER 40    // parent ranks with fresh children, wave after wave
#define NFD_B_FLOOD_RESULTS 41     // (value, gradient) of a chunk of claimed points
// A meshed level above the finest (progressive extractions): its value and predicted lists
// joined back into one value list (udf_predict.comp's NFD_PREDICT_JOIN), which the next level
// refines.
#define NFD_B_JOINED_VALUES 42
// A mesher's cells in order, 32 * parent rank + child (bitmap_compact.comp over per-parent
// child masks): the UDF's near cells, for udf_classify.comp's invocation per near cell; the cells
// that emit a triangle, for mc_emit.comp's.
#define NFD_B_NEAR_CELLS 43

#define NFD_LOCAL_SIZE 64          // every level and mesher kernel
#define NFD_LEVEL_PUSH_BYTES 64    // extract.glsl's LevelPush
#define NFD_POINT_CHUNK (1u << 20) // points of a list that refine_points writes for one evaluation

#endif
