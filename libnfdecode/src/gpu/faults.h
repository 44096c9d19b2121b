// Fault injection into the Vulkan layer, for the tests of what a failing driver does to the
// library (tests/cpp/test_gpu_faults.cpp): the `after`-th call of that kind from now (1 = the
// next) fails, later ones succeed again, 0 disarms.
//   DeviceCreation: vkCreateDevice returns VK_ERROR_INITIALIZATION_FAILED.
//   Allocation:     vkAllocateMemory returns VK_ERROR_OUT_OF_DEVICE_MEMORY.
//   Submission:     a submission's fence reports VK_ERROR_DEVICE_LOST; the context then stays
//                   lost, as a real lost device does.
// Process-wide and off unless a test arms it; every path it reaches is the real error path.
#pragma once

namespace nfd::gpu {

enum class Fault { DeviceCreation, Allocation, Submission, Count };
void inject_fault(Fault kind, int after);

}  // namespace nfd::gpu
