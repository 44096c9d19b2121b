// The job's counters (bindings.h): item counts that count_total.comp writes on the device and
// later kernels read, so that no count makes a round trip to the host between kernels. The
// includer defines COUNTERS_BINDING (its kernel family's binding number).
#ifndef NFD_COUNTERS_GLSL
#define NFD_COUNTERS_GLSL
#include "bindings.h"

layout(std430, binding = COUNTERS_BINDING) buffer Counters { uint counters[]; };

// The items of a dispatch sized for `capacity` items from item `first` on, whose total is in
// counter `slot` (NFD_NO_COUNTER: the capacity is the count). None at all once a total has
// exceeded the capacity it was given: what follows an overflow would read past buffers.
uint counted_items(uint capacity, uint slot, uint first) {
    if (counters[NFD_COUNTER_OVERFLOW] != 0u) return 0u;
    if (slot == NFD_NO_COUNTER) return capacity;
    uint total = counters[slot];
    return total <= first ? 0u : min(capacity, total - first);
}

#endif
