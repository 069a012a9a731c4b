#include "hal/v4l2/v4l2_source.hpp"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>

#include "hal/os/clock.hpp"

namespace zonemap::v4l2 {
namespace {

int xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do {
    r = ::ioctl(fd, request, arg);
  } while (r < 0 && errno == EINTR);
  return r;
}

std::string fourcc_text(std::uint32_t f) {
  const char c[5] = {static_cast<char>(f & 0xFF), static_cast<char>((f >> 8) & 0xFF),
                     static_cast<char>((f >> 16) & 0xFF), static_cast<char>((f >> 24) & 0xFF), 0};
  return c;
}

}  // namespace

V4l2FrameSource::V4l2FrameSource(const V4l2Config& config, const CameraModel& camera)
    : config_(config),
      camera_(camera),
      backoff_s_(config.reopen_backoff_min_s),
      intake_(config.time, camera) {}

V4l2Counters V4l2FrameSource::counters() const {
  V4l2Counters c;
  static_cast<BufferCounters&>(c) = intake_.counters();
  c.device_errors = device_errors_;
  c.reopens = reopens_;
  return c;
}

V4l2FrameSource::~V4l2FrameSource() {
  close_device();
}

hal::CameraFrame V4l2FrameSource::make_frame() const {
  hal::CameraFrame f;
  f.depth.assign(static_cast<std::size_t>(camera_.width) * static_cast<std::size_t>(camera_.height),
                 0);
  return f;
}

void V4l2FrameSource::close_device() {
  if (fd_ < 0) return;
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  xioctl(fd_, VIDIOC_STREAMOFF, &type);
  for (int i = 0; i < mapped_; ++i)
    munmap(mappings_[static_cast<std::size_t>(i)].start,
           mappings_[static_cast<std::size_t>(i)].length);
  mapped_ = 0;
  ::close(fd_);
  fd_ = -1;
}

bool V4l2FrameSource::open(std::string* error) {
  close_device();
  const std::string& dev = config_.device;
  const auto fail = [&](const std::string& what) {
    *error = dev + ": " + what;
    close_device();
    return false;
  };
  fd_ = ::open(dev.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    *error = dev + ": " + std::strerror(errno);
    return false;
  }
  v4l2_capability cap{};
  if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) < 0) return fail("not a V4L2 device (VIDIOC_QUERYCAP)");
  const std::uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING)) {
    return fail("no single-planar video capture with streaming I/O");
  }
  const std::uint32_t fourcc =
      config_.format == DepthFormat::kY16 ? V4L2_PIX_FMT_Y16 : V4L2_PIX_FMT_Z16;
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = static_cast<std::uint32_t>(camera_.width);
  fmt.fmt.pix.height = static_cast<std::uint32_t>(camera_.height);
  fmt.fmt.pix.pixelformat = fourcc;
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  if (xioctl(fd_, VIDIOC_S_FMT, &fmt) < 0)
    return fail(std::string("VIDIOC_S_FMT: ") + std::strerror(errno));
  // Drivers adjust what they cannot do: refuse anything but exactly the camera's format.
  if (fmt.fmt.pix.pixelformat != fourcc ||
      fmt.fmt.pix.width != static_cast<std::uint32_t>(camera_.width) ||
      fmt.fmt.pix.height != static_cast<std::uint32_t>(camera_.height)) {
    return fail("offers " + std::to_string(fmt.fmt.pix.width) + "x" +
                std::to_string(fmt.fmt.pix.height) + " " + fourcc_text(fmt.fmt.pix.pixelformat) +
                ", camera.yaml needs " + std::to_string(camera_.width) + "x" +
                std::to_string(camera_.height) + " " + fourcc_text(fourcc));
  }
  bytes_per_line_ = std::max<std::uint32_t>(fmt.fmt.pix.bytesperline,
                                            static_cast<std::uint32_t>(camera_.width) * 2);
  intake_.set_image_bytes(fmt.fmt.pix.sizeimage);
  v4l2_requestbuffers request{};
  request.count = static_cast<std::uint32_t>(std::clamp(config_.buffers, 2, 16));
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_REQBUFS, &request) < 0 || request.count < 2) {
    return fail("memory-mapped buffers refused (VIDIOC_REQBUFS)");
  }
  for (std::uint32_t i = 0; i < request.count && i < mappings_.size(); ++i) {
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    buf.index = i;
    if (xioctl(fd_, VIDIOC_QUERYBUF, &buf) < 0) return fail("VIDIOC_QUERYBUF");
    void* start = mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buf.m.offset);
    if (start == MAP_FAILED) return fail(std::string("mmap: ") + std::strerror(errno));
    mappings_[i] = {start, buf.length};
    mapped_ = static_cast<int>(i) + 1;
    if (xioctl(fd_, VIDIOC_QBUF, &buf) < 0) return fail("VIDIOC_QBUF");
  }
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_STREAMON, &type) < 0) return fail("VIDIOC_STREAMON");
  intake_.restart_sequence();
  ever_opened_ = true;
  return true;
}

bool V4l2FrameSource::reopen_due(double now_s) {
  if (now_s < next_reopen_s_) return false;
  std::string error;
  if (open(&error)) {
    ++reopens_;
    backoff_s_ = config_.reopen_backoff_min_s;
    return true;
  }
  next_reopen_s_ = now_s + backoff_s_;
  backoff_s_ = std::min(backoff_s_ * 2.0, config_.reopen_backoff_max_s);
  return false;
}

hal::FrameRead V4l2FrameSource::next(hal::CameraFrame* frame, int wait_ms, std::string* why) {
  if (fd_ < 0 && !(ever_opened_ && reopen_due(os::monotonic_now_s()))) {
    if (wait_ms > 0) ::poll(nullptr, 0, std::min(wait_ms, 50));  // no device: do not spin
    return hal::FrameRead::kNone;
  }
  pollfd p{fd_, POLLIN, 0};
  if (::poll(&p, 1, wait_ms) <= 0) return hal::FrameRead::kNone;
  v4l2_buffer buf{};
  buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buf.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_DQBUF, &buf) < 0) {
    if (errno == EAGAIN) return hal::FrameRead::kNone;
    // The device went away (unplugged, driver reset): reopen with backoff.
    ++device_errors_;
    close_device();
    next_reopen_s_ = os::monotonic_now_s() + backoff_s_;
    return hal::FrameRead::kNone;
  }
  hal::FrameRead result = hal::FrameRead::kRejected;
  if (buf.index < static_cast<std::uint32_t>(mapped_)) {
    DequeuedBuffer dequeued;
    dequeued.image = static_cast<const std::uint8_t*>(mappings_[buf.index].start);
    dequeued.bytes_per_line = bytes_per_line_;
    dequeued.bytes_used = buf.bytesused;
    dequeued.sequence = buf.sequence;
    // The driver's capture time (CLOCK_MONOTONIC for V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC).
    dequeued.timestamp_s = static_cast<double>(buf.timestamp.tv_sec) +
                           static_cast<double>(buf.timestamp.tv_usec) * 1e-6;
    dequeued.error_flag = (buf.flags & V4L2_BUF_FLAG_ERROR) != 0;
    result = intake_.take(dequeued, frame, why);
  } else if (why != nullptr) {
    why->assign("bad buffer index");
  }
  xioctl(fd_, VIDIOC_QBUF, &buf);  // back to the driver at once
  return result;
}

}  // namespace zonemap::v4l2
