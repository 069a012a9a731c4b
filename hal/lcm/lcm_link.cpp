#include "hal/lcm/lcm_link.hpp"

#include <lcm/lcm.h>
#include <poll.h>

#include <algorithm>
#include <chrono>
#include <cstring>

#include "hal/lcm/lcm_codec.hpp"
#include "hal/os/clock.hpp"

namespace zonemap::lcm_link {

LcmConnection::LcmConnection(std::string url, double backoff_min_s, double backoff_max_s)
    : url_(std::move(url)),
      backoff_min_s_(backoff_min_s),
      backoff_max_s_(backoff_max_s),
      backoff_s_(backoff_min_s) {}

LcmConnection::~LcmConnection() {
  if (lcm_ != nullptr) lcm_destroy(lcm_);
}

lcm_t* LcmConnection::get(double now_s) {
  if (lcm_ != nullptr) return lcm_;
  if (now_s < next_attempt_s_) return nullptr;
  lcm_ = lcm_create(url_.c_str());
  if (lcm_ == nullptr) {
    ++start_failures_;
    next_attempt_s_ = now_s + backoff_s_;
    backoff_s_ = std::min(backoff_s_ * 2.0, backoff_max_s_);
    return nullptr;
  }
  backoff_s_ = backoff_min_s_;
  return lcm_;
}

void LcmConnection::reset(double now_s) {
  if (lcm_ != nullptr) lcm_destroy(lcm_);
  lcm_ = nullptr;
  next_attempt_s_ = now_s + backoff_s_;
}

LcmPoseSource::LcmPoseSource(const std::string& url, const std::string& channel, bool world_z_up,
                             const InsGateConfig& gate, const Eigen::Isometry3d& body_T_camera,
                             double time_offset_s)
    : connection_(url),
      channel_(channel),
      world_z_up_(world_z_up),
      filter_(gate, body_T_camera, time_offset_s, "INS over LCM") {}

lcm_t* LcmPoseSource::subscribed(double now_s) {
  lcm_t* lcm = connection_.get(now_s);
  if (lcm != nullptr && lcm != subscribed_to_) {
    lcm_subscription_t* subscription =
        lcm_subscribe(lcm, channel_.c_str(), &LcmPoseSource::on_message, this);
    if (subscription == nullptr) {
      connection_.reset(now_s);
      return nullptr;
    }
    // LCM keeps 30 unhandled messages per subscription and silently drops the rest:
    // room for seconds of INS output between two polls.
    lcm_subscription_set_queue_capacity(subscription, kQueueCapacity);
    subscribed_to_ = lcm;
  }
  return lcm;
}

void LcmPoseSource::on_message(const lcm_recv_buf_t* rbuf, const char* /*channel*/, void* self) {
  auto* source = static_cast<LcmPoseSource*>(self);
  ++source->messages_;
  InsSolution solution;
  const InsDecode result =
      decode_ins_state(rbuf->data, rbuf->data_size, source->world_z_up_, &solution);
  if (result == InsDecode::kMalformed) {
    ++source->malformed_;
    source->filter_.log().log(hal::LogReason::kMalformedMessage, source->now_s_, source->name(),
                              "malformed ins_state_t (fingerprint or length)");
    return;
  }
  if (result == InsDecode::kWrongFrame) {
    ++source->wrong_frame_;
    source->filter_.log().log(hal::LogReason::kWrongWorldFrame, source->now_s_, source->name(),
                              "ins_state_t in another world frame than the map's");
    return;
  }
  ++source->solutions_;
  source->filter_.pass(solution, *source->sink_, source->now_s_);
}

hal::PollResult LcmPoseSource::poll(hal::PoseSink& sink, int wait_ms) {
  now_s_ = os::monotonic_now_s();
  lcm_t* lcm = subscribed(now_s_);
  if (lcm == nullptr) {
    filter_.log().log(hal::LogReason::kLinkDown, now_s_, name(),
                      "LCM provider not started (retrying with backoff)");
    return hal::PollResult::kIdle;
  }
  sink_ = &sink;
  const std::int64_t before = messages_;
  // Bounded: 256 messages a call; the first may wait.
  for (int i = 0; i < 256; ++i) {
    const int handled = lcm_handle_timeout(lcm, i == 0 ? wait_ms : 0);
    if (handled < 0) {
      connection_.reset(now_s_);
      subscribed_to_ = nullptr;
      break;
    }
    if (handled == 0) break;
  }
  sink_ = nullptr;
  return messages_ > before ? hal::PollResult::kGotData : hal::PollResult::kIdle;
}

hal::PoseSourceCounters LcmPoseSource::counters() const {
  hal::PoseSourceCounters c;
  c.messages = messages_;
  c.malformed = malformed_ + wrong_frame_;
  c.solutions = solutions_;
  c.poses_out = filter_.poses_out();
  c.link_errors = connection_.start_failures();
  c.gate = filter_.gate_counters();
  return c;
}

LcmLogPoseSource::LcmLogPoseSource(const std::string& channel, bool world_z_up,
                                   const InsGateConfig& gate,
                                   const Eigen::Isometry3d& body_T_camera, double time_offset_s)
    : channel_(channel),
      world_z_up_(world_z_up),
      filter_(gate, body_T_camera, time_offset_s, "INS LCM log") {}

bool LcmLogPoseSource::open(const std::string& path, std::string* error) {
  opened_ = reader_.open(path, error);
  return opened_;
}

void LcmLogPoseSource::open_memory(const std::uint8_t* data, std::size_t size) {
  reader_.open_memory(data, size);
  opened_ = true;
}

hal::PollResult LcmLogPoseSource::poll(hal::PoseSink& sink, int /*wait_ms*/) {
  if (!opened_) return hal::PollResult::kEnd;
  for (int i = 0; i < 4096; ++i) {
    LcmLogEvent event;
    const LcmLogRead read = reader_.next(&event);
    if (read == LcmLogRead::kEnd) return hal::PollResult::kEnd;
    if (read == LcmLogRead::kSkipped) {
      filter_.log().log(hal::LogReason::kDamagedLogRecord, last_time_s_, name(),
                        "damaged or oversized log event skipped");
      continue;
    }
    const double now = static_cast<double>(event.timestamp_us) * 1e-6;
    last_time_s_ = now;
    if (event.channel != channel_) continue;
    ++messages_;
    InsSolution solution;
    const InsDecode result = decode_ins_state(event.data, event.size, world_z_up_, &solution);
    if (result == InsDecode::kOk) {
      ++solutions_;
      filter_.pass(solution, sink, now);
    } else if (result == InsDecode::kMalformed) {
      ++malformed_;
      filter_.log().log(hal::LogReason::kMalformedMessage, now, name(),
                        "malformed ins_state_t (fingerprint or length)");
    } else {
      ++wrong_frame_;
      filter_.log().log(hal::LogReason::kWrongWorldFrame, now, name(),
                        "ins_state_t in another world frame than the map's");
    }
  }
  return hal::PollResult::kGotData;
}

hal::PoseSourceCounters LcmLogPoseSource::counters() const {
  hal::PoseSourceCounters c;
  c.messages = messages_;
  c.malformed = malformed_ + wrong_frame_ + reader_.damaged();
  c.solutions = solutions_;
  c.poses_out = filter_.poses_out();
  c.gate = filter_.gate_counters();
  return c;
}

LcmPublisher::LcmPublisher(const std::string& url, bool background_restart)
    : connection_(url), background_(background_restart) {
  if (background_) keeper_.start({"zonemap-lcm-keep"}, [this] { keep(); });
}

LcmPublisher::~LcmPublisher() {
  if (keeper_.started()) {
    stop_.store(true);
    wake_.notify_all();
    keeper_.join();
  }
}

void LcmPublisher::keep() {
  lcm_t* owned = nullptr;
  double backoff_s = 0.5;
  while (!stop_.load()) {
    if (live_.load(std::memory_order_acquire) == nullptr) {
      // Down (never started, or the publisher dropped it after an error).
      if (owned != nullptr) lcm_destroy(owned);
      owned = lcm_create(connection_.url().c_str());
      if (owned != nullptr) {
        live_.store(owned, std::memory_order_release);
        backoff_s = 0.5;
      } else {
        keeper_failures_.fetch_add(1, std::memory_order_relaxed);
        backoff_s = std::min(backoff_s * 2.0, 10.0);
      }
    }
    std::unique_lock<std::mutex> lock(mutex_);
    const double wait_s = live_.load() != nullptr ? 0.1 : backoff_s;
    wake_.wait_for(lock, std::chrono::duration<double>(wait_s), [this] { return stop_.load(); });
  }
  live_.store(nullptr);
  if (owned != nullptr) lcm_destroy(owned);
}

std::int64_t LcmPublisher::start_failures() const {
  return background_ ? keeper_failures_.load(std::memory_order_relaxed)
                     : connection_.start_failures();
}

bool LcmPublisher::publish(const char* channel, const void* data, std::size_t size, double now_s) {
  lcm_t* lcm = background_ ? live_.load(std::memory_order_acquire) : connection_.get(now_s);
  if (lcm == nullptr) {
    ++provider_down_;
    return false;
  }
  if (lcm_publish(lcm, channel, data, static_cast<unsigned int>(size)) != 0) {
    ++failed_;
    // Give it back: the keeper (or the next get() after the backoff) restarts it.
    if (background_) {
      live_.store(nullptr, std::memory_order_release);
    } else {
      connection_.reset(now_s);
    }
    return false;
  }
  ++published_;
  return true;
}

}  // namespace zonemap::lcm_link
