// One decode's counts on the device (device.h, Job): counters, totals, counted dispatches.
#include <cstring>

#include "device.h"

namespace nfd::gpu {
namespace {

constexpr uint32_t kRecordsPerBuffer = 1024;  // 12 KiB of VkDispatchIndirectCommand

struct ArgsPush {
    uint32_t capacity, slot, first, items_per_group, record;
};
static_assert(sizeof(ArgsPush) == NFD_ARGS_PUSH_BYTES, "dispatch_args.comp's ArgsPush");
struct TotalPush {
    uint32_t last, slot, capacity, unused;
};
static_assert(sizeof(TotalPush) == NFD_TOTAL_PUSH_BYTES, "count_total.comp's TotalPush");

}  // namespace

Job::~Job() {
    buffers_.release();
    device.vk->destroy(batch_);
}

nfd_result Job::init() {
    NFD_TRY(device.vk->create(&batch_));
    NFD_TRY(buffers_.make(NFD_COUNTER_SLOTS * 4, &counters_));
    return device.vk->upload(*counters_, 0, mirror_, sizeof mirror_);  // zeros
}

nfd_result Job::refresh() { return device.vk->download(*counters_, 0, mirror_, sizeof mirror_); }

nfd_result Job::new_slot(uint32_t* slot) {
    if (next_slot_ >= NFD_COUNTER_SLOTS) return NFD_ERROR_INTERNAL;
    *slot = next_slot_++;
    return NFD_SUCCESS;
}

nfd_result Job::dispatch(const Pipeline& pipeline, std::vector<Bind> buffers, const void* push,
                         Count count, uint32_t per_invocation) {
    if (pipeline.counters_binding != kNoCounters)
        buffers.push_back({pipeline.counters_binding, *counters_});
    Context& vk = *device.vk;
    if (count.slot == NFD_NO_COUNTER)
        return vk.dispatch(batch_, pipeline, buffers, push,
                           (uint64_t(count.capacity) + per_invocation - 1) / per_invocation);
    if (count.capacity == 0) return NFD_SUCCESS;
    if (records_ == args_.size() * kRecordsPerBuffer) {
        Buffer* args;
        NFD_TRY(buffers_.make(kRecordsPerBuffer * 12, &args));
        args_.push_back(args);
    }
    const Buffer& args = *args_[records_ / kRecordsPerBuffer];
    const uint32_t record = records_++ % kRecordsPerBuffer;
    const ArgsPush a{count.capacity, count.slot, count.first,
                     pipeline.local_size * per_invocation, record};
    NFD_TRY(vk.dispatch(batch_, device[Kernel::DispatchArgs],
                        {{NFD_B_SCAN_COUNTERS, *counters_}, {NFD_B_ARGS, args}}, &a, 1));
    return vk.dispatch_indirect(batch_, pipeline, buffers, push, args, record);
}

nfd_result Job::total(const Buffer& in, const Buffer& prefix, uint32_t elements, bool popcount,
                      uint32_t slot, uint32_t capacity) {
    if (elements == 0) return NFD_SUCCESS;  // the counter stays 0
    const TotalPush t{elements - 1, slot, capacity, 0};
    return device.vk->dispatch(
        batch_, device[popcount ? Kernel::CountTotalPopcount : Kernel::CountTotal],
        {{NFD_B_SCAN_IN, in}, {NFD_B_SCAN_OUT, prefix}, {NFD_B_SCAN_COUNTERS, *counters_}}, &t, 1);
}

nfd_result Job::begin() {
    if (!own) return NFD_SUCCESS;
    records_ = 0;  // the previous batch has run
    return device.vk->begin(batch_);
}

nfd_result Job::submit() {
    if (!own) return NFD_SUCCESS;
    NFD_TRY(device.vk->submit(batch_));
    return refresh();
}

nfd_result Job::sync() {
    NFD_TRY(submit());
    return begin();
}

}  // namespace nfd::gpu
