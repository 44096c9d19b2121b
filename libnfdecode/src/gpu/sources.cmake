# The Vulkan compute path, included by libnfdecode/CMakeLists.txt when NFD_WITH_VULKAN is ON.
# Its kernels come from the nfdecode_shaders object library (shaders/CMakeLists.txt).
set(NFD_GPU_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/gpu_decode.h
  ${CMAKE_CURRENT_LIST_DIR}/gpu_decode.cpp
  ${CMAKE_CURRENT_LIST_DIR}/vk_context.h
  ${CMAKE_CURRENT_LIST_DIR}/vk_context.cpp
)
