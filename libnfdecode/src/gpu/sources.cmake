# The Vulkan compute path, included by libnfdecode/CMakeLists.txt when NFD_WITH_VULKAN is ON.
# Its kernels come from the nfdecode_shaders object library (shaders/CMakeLists.txt).
set(NFD_GPU_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/gpu_decode.h
  ${CMAKE_CURRENT_LIST_DIR}/gpu_decode.cpp
  ${CMAKE_CURRENT_LIST_DIR}/device.h
  ${CMAKE_CURRENT_LIST_DIR}/device.cpp
  ${CMAKE_CURRENT_LIST_DIR}/faults.h
  ${CMAKE_CURRENT_LIST_DIR}/field.cpp
  ${CMAKE_CURRENT_LIST_DIR}/job.cpp
  ${CMAKE_CURRENT_LIST_DIR}/levels.h
  ${CMAKE_CURRENT_LIST_DIR}/levels.cpp
  ${CMAKE_CURRENT_LIST_DIR}/marching.cpp
  ${CMAKE_CURRENT_LIST_DIR}/mesh_sdf.cpp
  ${CMAKE_CURRENT_LIST_DIR}/mesh_udf.cpp
  ${CMAKE_CURRENT_LIST_DIR}/progressive.cpp
  ${CMAKE_CURRENT_LIST_DIR}/range_allocator.h
  ${CMAKE_CURRENT_LIST_DIR}/recording.cpp
  ${CMAKE_CURRENT_LIST_DIR}/vk_context.h
  ${CMAKE_CURRENT_LIST_DIR}/vk_context.cpp
)
