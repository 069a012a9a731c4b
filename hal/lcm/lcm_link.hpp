// LCM transports: INS poses from a live LCM bus (any provider URL, e.g.
// udpm://239.255.76.67:7667?ttl=0) or from an lcm-logger log, and zonemap's
// outputs (obstacle map, obstacle distances, health) published on LCM. Built on
// LCM's C API so no std::string is made per message. A provider that fails to
// start is retried with backoff; mapping never waits for it.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>

#include "hal/ins/pose_source.hpp"
#include "hal/lcm/lcm_log_reader.hpp"
#include "hal/os/task.hpp"

typedef struct _lcm_t lcm_t;
typedef struct _lcm_recv_buf_t lcm_recv_buf_t;

namespace zonemap::lcm_link {

// An lcm_t that (re)creates itself with exponential backoff.
class LcmConnection {
 public:
  explicit LcmConnection(std::string url, double backoff_min_s = 0.5, double backoff_max_s = 10.0);
  ~LcmConnection();
  LcmConnection(const LcmConnection&) = delete;
  LcmConnection& operator=(const LcmConnection&) = delete;
  // The lcm_t when the provider is up (creating it when due), else null.
  lcm_t* get(double now_s);
  // Drops the provider (after an error); the next get() retries after the backoff.
  void reset(double now_s);
  const std::string& url() const { return url_; }
  std::int64_t start_failures() const { return start_failures_; }

 private:
  std::string url_;
  lcm_t* lcm_ = nullptr;
  double backoff_min_s_, backoff_max_s_, backoff_s_, next_attempt_s_ = -1e300;
  std::int64_t start_failures_ = 0;
};

class LcmPoseSource final : public hal::PoseSource {
 public:
  LcmPoseSource(const std::string& url, const std::string& channel, bool world_z_up,
                const InsGateConfig& gate, const Eigen::Isometry3d& body_T_camera,
                double time_offset_s);
  hal::PollResult poll(hal::PoseSink& sink, int wait_ms) override;
  hal::PoseSourceCounters counters() const override;
  const char* name() const override { return "INS over LCM"; }
  // For in-process tests (memq://): the provider this source listens on.
  lcm_t* provider(double now_s) { return subscribed(now_s); }
  static constexpr int kQueueCapacity = 1024;

 private:
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* self);
  lcm_t* subscribed(double now_s);

  LcmConnection connection_;
  std::string channel_;
  bool world_z_up_;
  hal::InsPoseFilter filter_;
  lcm_t* subscribed_to_ = nullptr;
  hal::PoseSink* sink_ = nullptr;  // during poll()
  double now_s_ = 0.0;
  std::int64_t messages_ = 0, malformed_ = 0, wrong_frame_ = 0, solutions_ = 0;
};

class LcmLogPoseSource final : public hal::PoseSource {
 public:
  LcmLogPoseSource(const std::string& channel, bool world_z_up, const InsGateConfig& gate,
                   const Eigen::Isometry3d& body_T_camera, double time_offset_s);
  bool open(const std::string& path, std::string* error);
  void open_memory(const std::uint8_t* data, std::size_t size);  // tests, fuzzing
  hal::PollResult poll(hal::PoseSink& sink, int wait_ms) override;
  hal::PoseSourceCounters counters() const override;
  const char* name() const override { return "INS LCM log"; }

 private:
  std::string channel_;
  bool world_z_up_;
  hal::InsPoseFilter filter_;
  LcmLogReader reader_;
  bool opened_ = false;
  double last_time_s_ = 0.0;
  std::int64_t messages_ = 0, malformed_ = 0, wrong_frame_ = 0, solutions_ = 0;
};

// Where encoded messages go: an LCM provider (LcmPublisher) or, on a desk, a log.
class LcmMessageOut {
 public:
  virtual ~LcmMessageOut() = default;
  virtual bool publish(const char* channel, const void* data, std::size_t size, double now_s) = 0;
};

// Publishes encoded messages; counts what could not be sent. With
// background_restart the provider is (re)started by a keeper thread, so a provider
// that is down never costs the publishing (real-time) thread an allocation: the
// publisher only ever loads an atomic pointer.
class LcmPublisher final : public LcmMessageOut {
 public:
  explicit LcmPublisher(const std::string& url, bool background_restart = false);
  ~LcmPublisher() override;
  LcmPublisher(const LcmPublisher&) = delete;
  LcmPublisher& operator=(const LcmPublisher&) = delete;
  bool publish(const char* channel, const void* data, std::size_t size, double now_s) override;
  std::int64_t published() const { return published_; }
  std::int64_t failed() const { return failed_; }
  std::int64_t provider_down() const { return provider_down_; }
  std::int64_t start_failures() const;
  // True while the provider is up (with a keeper: once it has started it).
  bool ready() const { return background_ ? live_.load() != nullptr : true; }

 private:
  void keep();

  LcmConnection connection_;  // without a keeper
  bool background_;
  std::atomic<lcm_t*> live_{nullptr};  // with a keeper: the provider, null while down
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> keeper_failures_{0};
  std::mutex mutex_;  // the keeper's sleep only, never taken by the publisher
  std::condition_variable wake_;
  os::Task keeper_;
  std::int64_t published_ = 0, failed_ = 0, provider_down_ = 0;
};

}  // namespace zonemap::lcm_link
