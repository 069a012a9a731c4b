#include "runtime/ins_stage.hpp"

#include "hal/os/allocation_counter.hpp"

namespace zonemap::runtime {
namespace {

struct BufferSink final : hal::PoseSink {
  PoseBuffer<512>* buffer = nullptr;
  os::Doorbell* mapping_bell = nullptr;
  void push(const PoseSample& p) override {
    buffer->push(p);
    mapping_bell->ring();  // a mapper waiting for this pose looks again
  }
};

}  // namespace

InsStage::InsStage(Links& links, hal::PoseSource& source) : links_(links), source_(source) {}

void InsStage::run() {
  BufferSink sink;
  sink.buffer = &links_.poses;
  sink.mapping_bell = &links_.mapping_bell;
  os::AllocationScope scope;
  while (!links_.mapping_done.load(std::memory_order_acquire)) {
    const hal::PollResult r = source_.poll(sink, 20);
    links_.ins.store(source_.counters());
    if (r == hal::PollResult::kEnd) break;
  }
  const os::AllocationCounts counted = scope.counted();
  stats_.ins_thread_allocations = counted.allocations;
  stats_.ins_thread_frees = counted.frees;
}

}  // namespace zonemap::runtime
