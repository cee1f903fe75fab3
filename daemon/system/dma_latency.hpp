#pragma once
/// \file
/// Holds /dev/cpu_dma_latency open with a target written to it, as cyclictest
/// does. Why: while any process holds it, the kernel keeps CPUs out of deep
/// idle states; measured here, without it p99 wake-up latency rose from
/// 60-380 us to 1.4-1.8 ms. The request lasts exactly as long as this object.

#include <cstdint>
#include <string>

namespace hapticd::daemon::system {

class CpuDmaLatencyRequest {
 public:
  CpuDmaLatencyRequest() noexcept = default;
  /// Open `path` and write `max_latency_us` (binary int32). On failure the
  /// object is not held() and `error` (if given) says why. Non-RT.
  static CpuDmaLatencyRequest open(std::int32_t max_latency_us = 0, std::string* error = nullptr,
                                   const char* path = "/dev/cpu_dma_latency");
  CpuDmaLatencyRequest(CpuDmaLatencyRequest&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
  CpuDmaLatencyRequest& operator=(CpuDmaLatencyRequest&& o) noexcept;
  CpuDmaLatencyRequest(const CpuDmaLatencyRequest&) = delete;
  CpuDmaLatencyRequest& operator=(const CpuDmaLatencyRequest&) = delete;
  ~CpuDmaLatencyRequest();

  bool held() const noexcept { return fd_ >= 0; }
  void release() noexcept;

 private:
  int fd_ = -1;
};

}  // namespace hapticd::daemon::system
