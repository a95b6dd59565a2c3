// Starts subscribers' writes on a thread of its own, so that the simulation's thread, which
// learns of every new frame first, never does the transport's work itself.
//
// Why: FrameHub::Publish tells each subscriber's listener of a new frame on the simulation's
// thread, and gRPC's StartWrite can push the write through the transport on the calling thread.
// While it does, the solver's other OpenMP threads wait for the simulation's thread at their
// next barrier (publish_frames with 4 subscribers: 2.75 ms per frame before, 1.70 ms after;
// bench/README.md, "Server"). A listener schedules
// its stream here instead, which costs the simulation's thread one queue push.
#pragma once

#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

namespace dysa::service {

class WriteStarter {
 public:
  class Writer {
   public:
    virtual ~Writer() = default;
    // Starts the next write if none is in flight; called on the starter's thread.
    virtual void StartNextWrite() = 0;
  };

  WriteStarter();
  // Joins the thread; writers still queued are dropped without a call.
  ~WriteStarter();
  WriteStarter(const WriteStarter&) = delete;
  WriteStarter& operator=(const WriteStarter&) = delete;

  // Queues a call of writer->StartNextWrite(), unless one is queued already. Never waits for a
  // write.
  void Schedule(Writer* writer);
  // Drops the writer's queued call and waits for a call in progress to return: after Forget,
  // the starter never touches `writer` again.
  void Forget(Writer* writer);

 private:
  void Loop();

  std::mutex mu_;
  std::condition_variable queued_;
  std::condition_variable call_returned_;
  std::deque<Writer*> queue_;
  Writer* calling_ = nullptr;
  bool stop_ = false;
  std::thread thread_;  // last: starts once the members above exist
};

}  // namespace dysa::service
